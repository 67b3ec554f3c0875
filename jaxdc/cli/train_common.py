"""The flags both training command lines (``train.dcp``, ``train.dcg``) share, and how they settle.

:func:`add_a2c_arguments` adds the A2C hyperparameters of section 4.5 / 5.5.2,
the learner options beside Algorithm 10, several seeds, devices, and the
run-control flags; :func:`a2c_settings` turns them into
:class:`~jaxdc.agents.a2c.A2CConfig` keyword arguments (each flag's default is
the ``A2CConfig`` field it sets, so the two cannot drift apart) and
:func:`run_control` into the :class:`~jaxdc.training.loop.RunControl` of the
run loop (:mod:`jaxdc.training.loop`).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import nonnegative_float, positive_float, positive_int, seed, seed_list, unit_interval
from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.io import check_output_folder
from jaxdc.training.loop import LAYOUTS, RunControl

#: Exit status of a run stopped by a NaN loss.
EXIT_NAN = 3
#: ``A2CConfig`` field -> the attribute of the parsed arguments that sets it (the flag is its dashed form).
A2C_FLAGS = {"total_steps": "steps", "num_envs": "envs", "t_max": "t_max", "lr": "lr", "gamma": "gamma",
             "entropy_coef": "entropy", "value_coef": "value_coef", "max_grad_norm": "max_grad_norm",
             "reset_slots": "reset_slots", "gae_lambda": "gae_lambda", "clip_eps": "clip_eps",
             "epochs": "epochs", "minibatches": "minibatches", "normalize_advantages": "normalize_advantages"}
#: The learner options beside Algorithm 10 (not in the thesis; docs/learning.md) and their faithful defaults.
LEARNER_OPTIONS = {f.name: f.default for f in dataclasses.fields(A2CConfig)
                   if f.name in ("gae_lambda", "clip_eps", "epochs", "minibatches", "normalize_advantages")}
_DEFAULT = {f.name: f.default for f in dataclasses.fields(A2CConfig)}


def flag(field: str) -> str:
    """The command-line flag that sets ``A2CConfig`` field ``field`` (e.g. ``"--entropy"`` for ``entropy_coef``)."""
    return "--" + A2C_FLAGS[field].replace("_", "-")


def add_a2c_arguments(p: argparse.ArgumentParser, eval_every: int = 100_000, eval_episodes: int = 500) -> None:
    """The A2C hyperparameters (defaults: the ``A2CConfig`` fields, i.e. sections 4.5 and 5.5.2), the learner
    options beside Algorithm 10, several seeds and devices, and the run-control flags."""
    d = _DEFAULT
    p.add_argument("--steps", type=positive_int("--steps"), default=d["total_steps"],
                   help="T_max: environment steps in total (the learning rate reaches 0 there)")
    p.add_argument("--seed", type=seed("--seed"), default=0, help="seed of the run (0 .. 2**32 - 1)")
    p.add_argument("--seeds", type=seed_list("--seeds"), default=None,
                   help="several independent runs at once (vmapped), e.g. 0,1,2; replaces --seed")
    p.add_argument("--envs", type=positive_int("--envs"), default=d["num_envs"],
                   help="parallel environments (16 threads)")
    p.add_argument("--devices", type=positive_int("--devices"), default=None,
                   help="devices to split the environment batch over (default: all; --envs must be a multiple)")
    p.add_argument("--t-max", type=positive_int("--t-max"), default=d["t_max"], help="rollout length per update")
    p.add_argument("--lr", type=positive_float("--lr"), default=d["lr"], help="initial learning rate")
    p.add_argument("--gamma", type=unit_interval("--gamma"), default=d["gamma"])
    p.add_argument("--entropy", type=nonnegative_float("--entropy"), default=d["entropy_coef"],
                   help="entropy bonus weight (default 0.01 as in A3C; 0 for the thesis' two loss terms)")
    p.add_argument("--value-coef", type=nonnegative_float("--value-coef"), default=d["value_coef"])
    p.add_argument("--max-grad-norm", type=positive_float("--max-grad-norm"), default=d["max_grad_norm"])
    p.add_argument("--reset-slots", type=positive_int("--reset-slots"), default=d["reset_slots"],
                   help="fresh initial states drawn per step (default: one per environment)")
    g = p.add_argument_group("learner options beside Algorithm 10 (not in the thesis; see docs/learning.md)")
    g.add_argument("--gae-lambda", type=unit_interval("--gae-lambda"), default=d["gae_lambda"],
                   help="lambda-returns / GAE (1: the n-step returns of Algorithm 10)")
    g.add_argument("--clip-eps", type=unit_interval("--clip-eps", open_interval=True), default=d["clip_eps"],
                   help="PPO clipping of the probability ratio (default: none, plain policy gradient)")
    g.add_argument("--epochs", type=positive_int("--epochs"), default=d["epochs"], help="passes over each rollout")
    g.add_argument("--minibatches", type=positive_int("--minibatches"), default=d["minibatches"],
                   help="shuffled minibatches per pass (must divide envs * t-max)")
    g.add_argument("--normalize-advantages", action="store_true", help="standardize advantages per minibatch")
    p.add_argument("--layout", choices=LAYOUTS, default="loop",
                   help="loop: one jitted update per Python iteration (faster on CPU); scan: updates in lax.scan")
    p.add_argument("--resume", action="store_true", help="continue from the latest checkpoint in --out")
    p.add_argument("--eval-every", type=positive_int("--eval-every"), default=eval_every,
                   help="environment steps between evaluations and checkpoints")
    p.add_argument("--eval-episodes", type=positive_int("--eval-episodes"), default=eval_episodes)
    p.add_argument("--greedy-eval", action="store_true", help="evaluate the argmax policy instead of sampling")
    p.add_argument("--keep", type=positive_int("--keep"), default=3, help="checkpoints to keep")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_config_arguments(p: argparse.ArgumentParser, problem: str) -> None:
    """``--config NAME|FILE`` (a named configuration or a run's ``config.json``, :mod:`jaxdc.training.configs`)
    and ``--list-configs``."""
    p.add_argument("--config", metavar="NAME|FILE",
                   help="start from a named configuration (the recipe of a shipped network; --list-configs) or a "
                        "run's config.json (retrain that run); flags given as well override it")
    p.add_argument("--list-configs", action="store_true", help="print the named configurations and exit")


def parse_with_config(p: argparse.ArgumentParser, argv, problem: str):
    """The parsed arguments, ``--config`` expanded into flags placed before the given ones (so those override it);
    ``None`` after ``--list-configs`` printed the names. A bad configuration is a usage error (exit 2)."""
    from jaxdc.training import configs

    argv = list(sys.argv[1:] if argv is None else argv)
    if "--list-configs" in argv:
        print(configs.listing(problem))
        return None
    try:
        argv = configs.expand(argv, problem)
    except ValueError as e:
        p.error(str(e))
    return p.parse_args(argv)


def a2c_settings(args, fields=tuple(A2C_FLAGS)) -> dict:
    """``A2CConfig`` keyword arguments from the parsed flags of :func:`add_a2c_arguments` (``fields``: which)."""
    return {f: getattr(args, A2C_FLAGS[f]) for f in fields}


def learner_options_set(args) -> list[str]:
    """The flags of the learner options beside Algorithm 10 that ``args`` moves off their faithful default."""
    return [flag(f) for f, default in LEARNER_OPTIONS.items() if getattr(args, A2C_FLAGS[f]) != default]


def run_control(args, out: str) -> RunControl:
    """The :class:`~jaxdc.training.loop.RunControl` of the parsed run-control flags, into run folder ``out``."""
    return RunControl(out=out, seeds=tuple(args.seeds or [args.seed]), devices=args.devices, resume=args.resume,
                      eval_every=args.eval_every, keep=args.keep, layout=args.layout, progress=not args.no_progress,
                      tensorboard=bool(getattr(args, "tensorboard", False)))


def seed_tag(args) -> str:
    """The seeds of a run as they appear in its default folder name (``0``, ``0-1-2``)."""
    return "-".join(map(str, args.seeds or [args.seed]))


def training_energy(name: str):
    """argparse type: an energy budget a training run can use, a finite number in ``(0, 2**24]``.

    An unlimited budget (``inf``) is refused: the trained network would read a constant energy plane and
    learn nothing about recharging; evaluate with ``eval.dcp``/``eval.dcg`` for unlimited energy.
    """
    finite = positive_float(name, high=MAX_FINITE_ENERGY)

    def parse(text):
        try:
            if float(text) == float("inf"):
                raise argparse.ArgumentTypeError(
                    f"{name} must be a finite number in (0, {MAX_FINITE_ENERGY:g}] for training, got {text!r} "
                    "(unlimited energy is an evaluation setting: eval.dcp / eval.dcg accept it)")
        except ValueError:
            pass
        return finite(text)

    return parse


def check_outputs(out: str, tensorboard: bool = False) -> None:
    """Refuse, before any work, a run folder (and its ``tb/``) that cannot be created or written."""
    check_output_folder(out, "--out")
    if tensorboard:
        check_output_folder(os.path.join(out, "tb"), "--tensorboard folder")


def fmt(x, spec: str = ".3f") -> str:
    """``x`` formatted with ``spec``, or ``n/a`` for an undefined statistic (``None``)."""
    return "n/a" if x is None else format(x, spec)
