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
from collections.abc import Callable, Iterable
from typing import Any

from jaxdc.agents.a2c import A2CConfig
from jaxdc.cli.args import nonnegative_float, positive_float, positive_int, seed, seed_list, unit_interval
from jaxdc.cli.cluster import add_cluster_arguments, cluster
from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.training import presets
from jaxdc.training.fields import dest, flag, number_text
from jaxdc.training.loop import LAYOUTS, RunControl, check_run_folder

#: Exit status of a run stopped by a NaN loss.
EXIT_NAN = 3
#: The ``A2CConfig`` fields that both command lines set (each by :func:`jaxdc.training.fields.flag` of it).
A2C_FLAGS = ("total_steps", "num_envs", "t_max", "lr", "gamma", "entropy_coef", "value_coef", "max_grad_norm",
             "reset_slots", "gae_lambda", "clip_eps", "epochs", "minibatches", "normalize_advantages")
#: The learner options beside Algorithm 10 (not in the thesis; docs/learning.md) and their faithful defaults.
LEARNER_OPTIONS = {f.name: f.default for f in dataclasses.fields(A2CConfig)
                   if f.name in ("gae_lambda", "clip_eps", "epochs", "minibatches", "normalize_advantages")}
_DEFAULT = {f.name: f.default for f in dataclasses.fields(A2CConfig)}


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
    p.add_argument("--resume-step", type=positive_int("--resume-step"), default=None, metavar="STEP",
                   help="with --resume: continue from checkpoint STEP instead (the later checkpoints are deleted)")
    p.add_argument("--eval-every", type=positive_int("--eval-every"), default=eval_every,
                   help="environment steps between evaluations and checkpoints")
    p.add_argument("--eval-episodes", type=positive_int("--eval-episodes"), default=eval_episodes)
    p.add_argument("--greedy-eval", action="store_true", help="evaluate the argmax policy instead of sampling")
    p.add_argument("--keep", type=positive_int("--keep"), default=3, help="checkpoints to keep")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_cluster_arguments(p)  # several processes: --coordinator --num-processes --process-id, --auto-cluster


def add_config_arguments(p: argparse.ArgumentParser, problem: str) -> None:
    """``--config NAME|FILE`` (a named configuration of :mod:`jaxdc.training.presets` or a run's ``config.json``)
    and ``--list-configs``."""
    p.add_argument("--config", metavar="NAME|FILE",
                   help="start from a named configuration (the recipe of a shipped network; --list-configs) or a "
                        "run's config.json (retrain that run); flags given as well override it")
    p.add_argument("--list-configs", action="store_true", help="print the named configurations and exit")


#: Reads a run's ``config.json`` (already parsed) into ``(settings, seeds)``: the problem's
#: ``settings_from_metadata`` (:func:`jaxdc.training.dcp.settings_from_metadata`, ...).
FromMetadata = Callable[[object, str], tuple[Any, tuple[int, ...]]]


def _pop_config(argv: list[str]) -> tuple[str | None, list[str]]:
    """``(value of --config, argv without it)``; ``ValueError`` for a repeated or empty ``--config``."""
    found = [i for i, a in enumerate(argv) if a == "--config" or a.startswith("--config=")]
    if not found:
        return None, argv
    if len(found) > 1:
        raise ValueError("--config given more than once")
    i = found[0]
    if argv[i] == "--config":
        if i + 1 >= len(argv):
            raise ValueError("--config needs a NAME or a run's config.json")
        return argv[i + 1], argv[:i] + argv[i + 2:]
    return argv[i].split("=", 1)[1], argv[:i] + argv[i + 1:]


def _word(v: Any) -> str:
    return number_text(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)


def _checked(action: argparse.Action, field: str, v: Any, where: str) -> Any:
    """``v`` as the flag of ``action`` would read it (its type and choices check it), or ``ValueError``."""
    if action.nargs == 0:  # a switch
        if not isinstance(v, bool):
            raise ValueError(f"{where}: {field}={v!r} must be true or false ({action.option_strings[0]})")
        return v
    if isinstance(v, bool) or isinstance(v, dict):
        raise ValueError(f"{where}: {field}={v!r} is no value of {action.option_strings[0]}")
    if action.nargs is None and isinstance(v, (list, tuple)):
        v = ",".join(map(_word, v))  # a comma-separated list (--strategies, --seeds)
    values = list(v) if isinstance(v, (list, tuple)) else [v]
    if isinstance(action.nargs, int) and len(values) != action.nargs:
        raise ValueError(f"{where}: {field}={v!r} must hold {action.nargs} values ({action.option_strings[0]})")
    out = []
    for x in values:
        if isinstance(x, (list, tuple, dict)) or isinstance(x, bool):
            raise ValueError(f"{where}: {field}={v!r} is no value of {action.option_strings[0]}")
        try:
            x = action.type(_word(x)) if action.type is not None else _word(x)
        except (argparse.ArgumentTypeError, TypeError, ValueError) as e:
            raise ValueError(f"{where}: {e}") from None
        if action.choices is not None and x not in action.choices:
            raise ValueError(f"{where}: {field}={x!r} is not one of {action.option_strings[0]}'s choices "
                             f"{tuple(action.choices)}")
        out.append(x)
    return tuple(out) if isinstance(action.nargs, int) or action.nargs in ("+", "*") else out[0]


def set_field_defaults(p: argparse.ArgumentParser, fields: Iterable[tuple[str, Any]], where: str,
                       no_flag_defaults: dict[str, Any] | None = None) -> None:
    """Make the settings ``fields`` (``(field, value)``; ``None``: leave the default) the parser's defaults, each
    checked as its flag checks a typed value; a field no flag sets must hold ``no_flag_defaults[field]``."""
    actions = {a.dest: a for a in p._actions}
    defaults = {}
    for field, v in fields:
        action = actions.get(dest(field))
        if action is None:
            default = (no_flag_defaults or {}).get(field, v)
            if v != default:
                raise ValueError(f"{where}: {field}={v!r} is set by no flag of {p.prog} (its default is {default!r})")
            continue
        if v is not None:
            defaults[action.dest] = _checked(action, field, v, where)
    p.set_defaults(**defaults)


def _run_fields(settings: Any, seeds: tuple[int, ...], problem: str) -> list[tuple[str, Any]]:
    """The settings fields a run's ``config.json`` records (:data:`jaxdc.metadata.RUN_KEYS`), its algorithm's
    fields and its seeds."""
    from jaxdc.metadata import RECORDS, RUN_KEYS

    recorded = [k for k in RUN_KEYS[problem]
                if k not in ("format", "problem", "seed", "seeds", "algorithm", *RECORDS)]
    out = [(k, getattr(settings, k)) for k in recorded]
    out += [(k, v) for k, v in dataclasses.asdict(settings.config).items() if k != "aux_coef" or problem == "dcp"]
    return out + ([("seeds", list(seeds))] if len(seeds) > 1 else [("seed", seeds[0])])


def config_defaults(p: argparse.ArgumentParser, value: str, problem: str, from_metadata: FromMetadata) -> None:
    """Make configuration ``value`` the parser's defaults: a preset of :mod:`jaxdc.training.presets` by name, or
    a run's ``config.json`` (or its folder) read by ``from_metadata``. ``ValueError`` for an unknown name, a file
    that is not a run's ``config.json``, a configuration of the other problem, or a value its flag refuses."""
    from jaxdc.io import read_json

    if value in presets.EVERY:
        preset = presets.EVERY[value]
        if preset.problem != problem:
            raise ValueError(f"--config {value!r} is a {preset.problem.upper()} configuration; use "
                             f"python -m train.{preset.problem} --config {value}")
        set_field_defaults(p, preset.fields().items(), f"--config {value}")
        return
    path = config_file(value)
    if not os.path.isfile(path):
        raise ValueError(f"--config {value!r} is neither a named configuration ({', '.join(presets.names(problem))})"
                         " nor a run's config.json")
    where = f"--config {path}"
    try:
        meta = read_json(path, "a run folder's config.json")
    except ValueError as e:
        raise ValueError(f"{where}: not a readable JSON file ({e})") from None
    settings, seeds = from_metadata(meta, where)
    no_flag = {f.name: f.default for f in dataclasses.fields(settings.config)}
    set_field_defaults(p, _run_fields(settings, seeds, problem), where, no_flag)


def config_file(value: str | None) -> str | None:
    """The file ``--config value`` reads: ``None`` for no ``--config`` or a named configuration, a folder's
    ``config.json``, else ``value``."""
    if value is None or value in presets.EVERY:
        return None
    return os.path.join(value, "config.json") if os.path.isdir(value) else value


def parse_with_config(p: argparse.ArgumentParser, argv: list[str] | None, problem: str,
                      from_metadata: FromMetadata) -> argparse.Namespace | None:
    """The parsed arguments, ``--config`` made the parser's defaults (so flags given override it); ``None`` after
    ``--list-configs`` printed the names. A bad configuration is a usage error (exit 2)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--list-configs" in argv:
        print(presets.listing(problem))
        return None
    try:
        value, argv = _pop_config(argv)
        if value is not None:
            config_defaults(p, value, problem, from_metadata)
    except ValueError as e:
        p.error(str(e))
    args = p.parse_args(argv)
    args.config = value  # --config is read before the parse; its file is an input (no output may overwrite it)
    return args


def a2c_settings(args: argparse.Namespace, fields: Iterable[str] = A2C_FLAGS) -> dict[str, Any]:
    """``A2CConfig`` keyword arguments from the parsed flags of :func:`add_a2c_arguments` (``fields``: which)."""
    return {f: getattr(args, dest(f)) for f in fields}


def learner_options_set(args: argparse.Namespace) -> list[str]:
    """The flags of the learner options beside Algorithm 10 that ``args`` moves off their faithful default."""
    return [flag(f) for f, default in LEARNER_OPTIONS.items() if getattr(args, dest(f)) != default]


def run_control(args: argparse.Namespace, out: str) -> RunControl:
    """The :class:`~jaxdc.training.loop.RunControl` of the parsed run-control flags, into run folder ``out``."""
    return RunControl(out=out, seeds=tuple(args.seeds or [args.seed]), devices=args.devices, resume=args.resume,
                      resume_step=args.resume_step,
                      eval_every=args.eval_every, keep=args.keep, layout=args.layout, progress=not args.no_progress,
                      tensorboard=bool(getattr(args, "tensorboard", False)))


def seed_tag(args: argparse.Namespace) -> str:
    """The seeds of a run as they appear in its default folder name (``0``, ``0-1-2``)."""
    return "-".join(map(str, args.seeds or [args.seed]))


def training_energy(name: str) -> Callable[[str], float]:
    """argparse type: an energy budget a training run can use, a finite number in ``(0, 2**24]``.

    An unlimited budget (``inf``) is refused: the trained network would read a constant energy plane and
    learn nothing about recharging; evaluate with ``eval.dcp``/``eval.dcg`` for unlimited energy.
    """
    finite = positive_float(name, high=MAX_FINITE_ENERGY)

    def parse(text: str) -> float:
        try:
            if float(text) == float("inf"):
                raise argparse.ArgumentTypeError(
                    f"{name} must be a finite number in (0, {MAX_FINITE_ENERGY:g}] for training, got {text!r} "
                    "(unlimited energy is an evaluation setting: eval.dcp / eval.dcg accept it)")
        except ValueError:
            pass
        return finite(text)

    return parse


def run_outputs(out: str) -> list[str]:
    """The files and folders of run folder ``out`` that a run writes and a resume reads."""
    return [os.path.join(out, name) for name in ("config.json", "provenance.json", "metrics.csv", "checkpoints")]


def check_outputs(control: RunControl, config: str | None = None) -> None:
    """Refuse, before any work, a run folder that cannot be created or written, a file the run writes into it
    that cannot be written (``config.json`` and ``provenance.json`` of a fresh run, the metrics CSVs: a folder or
    a dangling symbolic link at the name) or is the ``--config`` file ``config``, and a ``checkpoints/`` or
    ``tb/`` that is a file, a dangling symbolic link or a link out of the run folder
    (:func:`jaxdc.training.loop.check_run_folder`)."""
    check_run_folder(control, "--out", inputs={"--config": config_file(config)})


def fmt(x: float | None, spec: str = ".3f") -> str:
    """``x`` formatted with ``spec``, or ``n/a`` for an undefined statistic (``None``)."""
    return "n/a" if x is None else format(x, spec)


def report_done(result: dict, details: Callable[[dict], str]) -> int:
    """After a run: :data:`EXIT_NAN` if a NaN loss stopped it, else 0 after one ``done:`` line per seed, with
    ``details(result)`` of that seed in parentheses."""
    if result["status"] == "nan":
        return EXIT_NAN
    for run_seed, r in result.get("per_seed", []):
        print(f"done: seed {run_seed}, {r['env_steps']} steps, eval reward {fmt(r['eval_reward'])} ({details(r)})")
    return 0


def _from_config(message: str, args: argparse.Namespace) -> str:
    """``message`` naming the ``--config`` file the refused settings may have come from (its values are the
    parser's defaults, so the flag a message names may be one the user never typed)."""
    path = config_file(getattr(args, "config", None))
    return message if path is None or path in message else f"{message} (the settings come from --config {path} " \
        "and the flags given)"


def train_from_command_line(parser: argparse.ArgumentParser, argv: list[str] | None, problem: str,
                            from_metadata: Any, settle: Callable[[argparse.Namespace], tuple[Any, RunControl]],
                            make_run: Callable[[Any, RunControl], Any],
                            check_more: Callable[[argparse.Namespace], None] | None = None) -> tuple | None:
    """Parse ``argv`` (with ``--config``), settle it, check the outputs (and ``check_more``), build the run and
    train it: ``(args, run, result)``, or ``None`` after ``--list-configs``. A bad value or combination is a usage
    error (exit 2) naming the flag."""
    from jaxdc.io import enable_compilation_cache
    from jaxdc.training import distributed
    from jaxdc.training.fields import SettingError

    args = parse_with_config(parser, argv, problem, from_metadata)
    if args is None:  # --list-configs
        return None
    try:
        settings, control = settle(args)
    except SettingError as e:
        parser.error(_from_config(e.render(), args))
    except (ValueError, TypeError) as e:
        parser.error(_from_config(str(e), args))
    try:
        check_outputs(control, getattr(args, "config", None))
        if check_more is not None:
            check_more(args)
        distributed.initialize(cluster(args))  # before any JAX computation
        enable_compilation_cache()
        run = make_run(settings, control)
        result = run.train()
    except SettingError as e:
        parser.error(e.render())
    except (ValueError, TypeError, MemoryError) as e:
        parser.error(str(e))
    return args, run, result
