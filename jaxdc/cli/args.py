"""argparse value types shared by the command lines (``train.*``, ``eval.*``).

Each type validates at the command line, outside jit, through the checks of
:mod:`jaxdc.core.validate`: a number must be finite (``inf`` only where a type
allows it), in its range and, for an integer, small enough for the int32
counters of the device code; a seed must lie in ``0 .. 2**32 - 1``. The error
names the flag, the value and the allowed range; argparse turns it into a usage
error with exit status 2.
"""

from __future__ import annotations

import argparse

from jaxdc.core.validate import INT32_MAX, SEED_MAX, check_float


def _number(name: str, text: str, **limits) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
    try:
        return check_float(name, v, **limits)
    except (TypeError, ValueError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _whole(name: str, text: str, low: int, high: int) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} must be an integer >= {low}, got {text!r}") from None
    if v < low:
        raise argparse.ArgumentTypeError(f"{name} must be an integer >= {low}, got {v}")
    if v > high:
        raise argparse.ArgumentTypeError(f"{name} must be an integer <= {high}, got {v}")
    return v


def real(name: str, low: float | None = None, high: float | None = None, low_open: bool = False,
         allow_inf: bool = False):
    """argparse type: a float in ``[low, high]`` (``(low, high]`` with ``low_open``; no bound when ``None``) that
    fits float32; NaN refused, ``+inf`` only with ``allow_inf``."""
    return lambda text: _number(name, text, low=low, high=high, low_open=low_open, allow_inf=allow_inf)


def positive_float(name: str, allow_inf: bool = False, high: float | None = None):
    """argparse type: a float > 0 (at most ``high``); finite unless ``allow_inf`` (then ``"inf"`` is accepted)."""
    return lambda text: _number(name, text, low=0.0, high=high, low_open=True, allow_inf=allow_inf)


def nonnegative_float(name: str, high: float | None = None):
    """argparse type: a finite float >= 0 (at most ``high``)."""
    return lambda text: _number(name, text, low=0.0, high=high)


def integer(name: str, low: int | None = None, high: int = INT32_MAX):
    """argparse type: an int in ``[low, high]`` (``low=None``: ``-high``); ``high`` defaults to the int32 limit."""
    return lambda text: _whole(name, text, -high if low is None else low, high)


def positive_int(name: str, high: int = INT32_MAX):
    """argparse type: an int in ``[1, high]``."""
    return integer(name, low=1, high=high)


def seed(name: str = "--seed"):
    """argparse type: a seed, an int in ``[0, 2**32 - 1]``."""
    return integer(name, low=0, high=SEED_MAX)


def unit_interval(name: str, open_interval: bool = False):
    """argparse type: a float in [0, 1] (in (0, 1) when ``open_interval``)."""
    span = "(0, 1)" if open_interval else "[0, 1]"

    def parse(text):
        v = _number(name, text)
        if not (0 < v < 1 if open_interval else 0 <= v <= 1):
            raise argparse.ArgumentTypeError(f"{name} must be in {span}, got {text!r}")
        return v

    return parse


def seed_list(name: str):
    """argparse type: distinct comma-separated seeds, e.g. ``0,1,2`` (each in ``[0, 2**32 - 1]``)."""
    def parse(text):
        try:
            seeds = [int(x) for x in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be comma-separated ints, e.g. 0,1,2, got {text!r}") from None
        for s in seeds:
            if not 0 <= s <= SEED_MAX:
                raise argparse.ArgumentTypeError(f"{name} must hold seeds in [0, {SEED_MAX}], got {s}")
        if len(set(seeds)) != len(seeds):
            raise argparse.ArgumentTypeError(f"{name} must be distinct, got {text!r}")
        return seeds

    return parse


def check_run_seed(run_seed: int | None, checkpoint: str | None, trainer: str) -> None:
    """``ValueError`` naming both flags if ``--run-seed`` comes without ``--checkpoint`` (the folder of a
    ``trainer --seeds`` run, e.g. ``train.dcg``, is where a run seed is picked)."""
    if run_seed is not None and not checkpoint:
        raise ValueError(f"--run-seed {run_seed} needs --checkpoint (a {trainer} --seeds run folder)")
