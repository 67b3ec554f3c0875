"""argparse value types shared by the command lines (``train.*``, ``eval.*``).

Each type validates at the command line, outside jit, and its error names the
flag and the value (the house rule for bad input); argparse turns it into a
usage error with exit status 2.
"""

from __future__ import annotations

import argparse
import math


def positive_float(name: str, allow_inf: bool = False):
    """argparse type: a float > 0; finite unless ``allow_inf`` (then ``"inf"`` is accepted)."""
    extra = " (or 'inf')" if allow_inf else ""

    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number > 0{extra}, got {text!r}") from None
        if not v > 0 or (math.isinf(v) and not allow_inf):
            raise argparse.ArgumentTypeError(f"{name} must be > 0{extra}, got {text!r}")
        return v

    return parse


def nonnegative_float(name: str):
    """argparse type: a float >= 0."""
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number >= 0, got {text!r}") from None
        if not v >= 0:
            raise argparse.ArgumentTypeError(f"{name} must be >= 0, got {text!r}")
        return v

    return parse


def integer(name: str, low: int | None = None):
    """argparse type: an int (``>= low`` when given)."""
    what = "an integer" if low is None else f"an integer >= {low}"

    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be {what}, got {text!r}") from None
        if low is not None and v < low:
            raise argparse.ArgumentTypeError(f"{name} must be {what}, got {v}")
        return v

    return parse


def positive_int(name: str):
    """argparse type: an int >= 1."""
    return integer(name, low=1)


def unit_interval(name: str, open_interval: bool = False):
    """argparse type: a float in [0, 1] (in (0, 1) when ``open_interval``)."""
    span = "(0, 1)" if open_interval else "[0, 1]"

    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number in {span}, got {text!r}") from None
        if not (0 < v < 1 if open_interval else 0 <= v <= 1):
            raise argparse.ArgumentTypeError(f"{name} must be in {span}, got {text!r}")
        return v

    return parse


def seed_list(name: str):
    """argparse type: distinct comma-separated ints, e.g. ``0,1,2``."""
    def parse(text):
        try:
            seeds = [int(x) for x in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be comma-separated ints, e.g. 0,1,2, got {text!r}") from None
        if len(set(seeds)) != len(seeds):
            raise argparse.ArgumentTypeError(f"{name} must be distinct, got {text!r}")
        return seeds

    return parse
