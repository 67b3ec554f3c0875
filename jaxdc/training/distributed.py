"""Train as several cooperating processes (``jax.distributed``): the cluster settings and the one process that writes.

Section 4.4.3 spreads Algorithm 10 over 16 threads of one machine; a run of
``train.dcp`` / ``train.dcg`` can instead be N processes, on one machine or on
several hosts, that form one mesh over all their devices
(:mod:`jaxdc.agents.parallel`). Every process runs the same program: it holds
the parameters (replicated), steps the environments of its own shard of the
batch, and takes part in the gradient all-reduce. Only process 0
(:func:`is_primary`) evaluates and writes the run folder (``config.json``,
metrics, checkpoints, a shipped file); the others write nothing, so they never
race on files. Resume reads the run folder on every process, so on several
hosts it must be on a file system they all see.

A :class:`Cluster` says how the processes find each other: explicitly (a
coordinator ``HOST:PORT``, the number of processes and this process's id) or
from the environment (``auto_cluster``: ``jax.distributed.initialize()`` reads SLURM,
Open MPI, ...). :func:`initialize` joins before any JAX computation; on CPU it
selects the gloo collectives itself. docs/scaling.md shows the command lines.
"""

from __future__ import annotations

import dataclasses

import jax

from jaxdc.core.validate import is_int
from jaxdc.training.fields import SettingError

#: The explicit settings, which come all together or not at all.
EXPLICIT = ("coordinator", "num_processes", "process_id")
#: The CPU collectives :func:`initialize` selects when none is chosen (JAX's default on CPU is none at all).
CPU_COLLECTIVES = "gloo"


def parse_address(text: str) -> tuple[str, int]:
    """``(host, port)`` of ``"HOST:PORT"`` (an IPv6 host in brackets: ``[::1]:1234``); ``ValueError`` naming the
    text unless the host is non-empty and the port an int in ``[1, 65535]``."""
    host, sep, port = str(text).rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ValueError(f"coordinator must be HOST:PORT with a port in [1, 65535], got {text!r}")
    return host, int(port)


@dataclasses.dataclass(frozen=True)
class Cluster:
    """How the processes of one run find each other (no field set: one process alone).

    Attributes:
      coordinator: ``HOST:PORT`` of process 0's coordination service.
      num_processes: the number of processes (>= 1).
      process_id: this process's id, in ``[0, num_processes)``.
      auto_cluster: let ``jax.distributed.initialize()`` read them from the environment (SLURM, Open MPI, ...);
        excludes the explicit fields.
    """

    coordinator: str | None = None
    num_processes: int | None = None
    process_id: int | None = None
    auto_cluster: bool = False

    def __post_init__(self) -> None:
        given = [f for f in EXPLICIT if getattr(self, f) is not None]
        if self.auto_cluster and given:
            raise SettingError("{0} finds the processes itself; drop " + ", ".join("{%d}" % (i + 1)
                                                                                  for i in range(len(given))),
                               "auto_cluster", *given)
        if given and len(given) < len(EXPLICIT):
            missing = [f for f in EXPLICIT if f not in given]
            raise SettingError("{0}, {1} and {2} come together; missing: "
                               + ", ".join("{%d}" % (3 + i) for i in range(len(missing))), *EXPLICIT, *missing)
        if not given:
            return
        try:
            parse_address(str(self.coordinator))
        except ValueError:
            raise SettingError(f"{{0}} must be HOST:PORT with a port in [1, 65535], got "
                               f"{SettingError.text(repr(self.coordinator))}", "coordinator") from None
        n, i = self.num_processes, self.process_id
        if not isinstance(n, int) or not is_int(n, numpy=False) or n < 1:
            raise SettingError(f"{{0}} must be an int >= 1, got {SettingError.text(repr(n))}", "num_processes")
        if not isinstance(i, int) or not is_int(i, numpy=False) or not 0 <= i < n:
            raise SettingError(f"{{0}} must be an int in [0, {n}) ({{1}} {n}), got {SettingError.text(repr(i))}",
                               "process_id", "num_processes")

    @property
    def active(self) -> bool:
        """Whether the run joins other processes at all."""
        return self.auto_cluster or self.coordinator is not None


def initialize(cluster: Cluster) -> None:
    """Join the run's other processes (nothing for a :class:`Cluster` that is not :attr:`~Cluster.active`).

    Call it before any JAX computation. Selects the gloo CPU collectives unless others were chosen (on a GPU
    or TPU host they are unused: the accelerator's own collectives reduce the batch).
    """
    if not cluster.active:
        return
    if getattr(jax.config, "jax_cpu_collectives_implementation", None) in (None, "", "none"):
        jax.config.update("jax_cpu_collectives_implementation", CPU_COLLECTIVES)
    if cluster.auto_cluster:
        jax.distributed.initialize()
    else:
        jax.distributed.initialize(coordinator_address=cluster.coordinator, num_processes=cluster.num_processes,
                                   process_id=cluster.process_id)


def is_primary() -> bool:
    """Whether this process writes the run's files (process 0; the only one without ``jax.distributed``)."""
    return jax.process_index() == 0
