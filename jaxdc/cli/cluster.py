"""The flags of a training run made of several processes (``train.dcp``, ``train.dcg``): docs/scaling.md.

``--coordinator HOST:PORT --num-processes N --process-id I`` (all three, in
every process), or ``--auto-cluster`` on a cluster whose environment
``jax.distributed.initialize()`` reads (SLURM, Open MPI, ...). They settle
into a :class:`jaxdc.training.distributed.Cluster`.
"""

from __future__ import annotations

import argparse

from jaxdc.cli.args import integer, positive_int
from jaxdc.training.distributed import Cluster, parse_address


def coordinator(text: str) -> str:
    """argparse type: ``HOST:PORT`` with a port in ``[1, 65535]``."""
    try:
        parse_address(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--coordinator must be HOST:PORT with a port in [1, 65535], "
                                         f"got {text!r}") from None
    return text


def add_cluster_arguments(p: argparse.ArgumentParser) -> None:
    """``--coordinator``, ``--num-processes``, ``--process-id`` and ``--auto-cluster``."""
    g = p.add_argument_group("several processes (jax.distributed; docs/scaling.md)")
    g.add_argument("--coordinator", type=coordinator, default=None, metavar="HOST:PORT",
                   help="process 0's address and a free port; every process passes the same")
    g.add_argument("--num-processes", type=positive_int("--num-processes"), default=None, metavar="N",
                   help="the number of processes of the run")
    g.add_argument("--process-id", type=integer("--process-id", low=0), default=None, metavar="I",
                   help="this process's id in [0, N); process 0 writes the run folder")
    g.add_argument("--auto-cluster", action="store_true",
                   help="find the processes from the environment (SLURM, Open MPI, ...) instead")


def cluster(args: argparse.Namespace) -> Cluster:
    """The :class:`Cluster` of the parsed flags (a ``SettingError`` names a bad combination)."""
    return Cluster(coordinator=args.coordinator, num_processes=args.num_processes, process_id=args.process_id,
                   auto_cluster=args.auto_cluster)
