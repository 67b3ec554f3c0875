"""The best shipped jaxdc learner of a thesis table, shown beside the table's faithful learned row.

Beyond the thesis: besides the networks trained with the thesis' recipe
(:mod:`jaxdc.dcp.analysis.table_learner`), jaxdc ships stronger learners of the same
network (longer training, the PPO-style option, other training
distributions; ``jaxdc/training/ship.py``). Which tables each may play is
data: the ``tables`` field of its metadata names them, followed by
``(beyond the thesis: <how it differs>)``. A table's *candidates* are the
shipped networks of its learned row's kind whose ``tables`` name it, marked
beyond the thesis and trained in the table's risk and energy.

:func:`best_row` plays every candidate in the table's setting on the same
episodes and seed as the other rows and keeps the one with the highest mean
reward (a choice made on the evaluation episodes themselves: with several
candidates it favours the luckiest by a fraction of a standard error, which is
small beside the differences it shows). A candidate trained with greedy
evaluation (``--greedy-eval`` in its training command) is played greedily, as
docs/learning.md reports it; the others as the faithful row is played.
"""

from __future__ import annotations

import dataclasses
import re

from jaxdc import pretrained
from jaxdc.dcp import learned as learned_lib
from jaxdc.dcp.analysis.table_learner import check_learner
from jaxdc.dcp.learned import observation_of

#: The mark in a shipped network's ``tables`` metadata that it goes beyond the thesis' recipe.
BEYOND = re.compile(r"\(beyond the thesis:\s*(?P<differs>[^)]*)\)")
#: The training command's flag of a network evaluated greedily during training.
GREEDY_FLAG = "--greedy-eval"


@dataclasses.dataclass(frozen=True)
class Candidate:
    """A shipped learner that may fill a table's best row."""

    name: str  # the shipped name (``--checkpoint NAME``)
    learned: learned_lib.Learned
    differs: str  # how its recipe differs from the thesis' (from its metadata)
    greedy: bool  # played greedily (it was trained with greedy evaluation)


def tables_of(meta: dict) -> tuple[str, ...]:
    """The table numbers a shipped network's ``tables`` metadata names (``"4.3, 4.6 (beyond ...)"`` -> 4.3, 4.6)."""
    head = BEYOND.split(meta.get("tables", ""))[0]
    return tuple(re.findall(r"\d+\.\d+", head))


def differs(meta: dict) -> str | None:
    """How a shipped network's recipe differs from the thesis' (``None``: it is a faithful one)."""
    m = BEYOND.search(meta.get("tables", ""))
    return m.group("differs").strip() if m else None


def candidates(spec, grid_size: int | None = None) -> list[Candidate]:
    """The shipped beyond-the-thesis learners of table ``spec``'s learned network that name the table and were
    trained in its risk and energy (none for a table without a learned row)."""
    if not spec.learned:
        return []
    net = spec.learned[0]
    out = []
    for name in pretrained.shipped_names("dcp"):
        meta = pretrained.read_metadata(pretrained.shipped("dcp", name))
        how = differs(meta)
        if meta.get("net") != net or how is None or spec.name not in tables_of(meta):
            continue
        if observation_of(meta) != "thesis":  # it reads another observation than a table's environment gives
            continue
        learned = learned_lib.load(pretrained.shipped("dcp", name), net=net, grid_size=grid_size)
        try:
            check_learner(spec, learned)
        except ValueError:
            continue
        out.append(Candidate(name, learned, how, GREEDY_FLAG in meta.get("command", "").split()))
    return out


def best_row(spec, evaluate, grid_size: int | None = None):
    """``(candidate, summary)`` of the candidate with the highest mean reward, or ``None`` when there is none.

    ``evaluate(candidate) -> summary`` plays one candidate (``summary["reward"]["mean"]``); each is played once.
    """
    played = [(c, evaluate(c)) for c in candidates(spec, grid_size)]
    if not played:
        return None
    return max(played, key=lambda cs: cs[1]["reward"]["mean"] if cs[1]["reward"]["mean"] is not None else -1e300)


def row_name(net: str) -> str:
    """The key of the best row in a table's rows: ``"<net> best"``."""
    return f"{net} best"
