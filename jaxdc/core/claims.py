"""The claims vocabulary shared by every problem: a thesis claim judged on our numbers.

A problem states its claims as data (the DRP's section 3.5 claims, the DCG's
section 5.5 claims) and judges them with its own measures; what comes out is
the same record everywhere, so the reports, the scorecard and the CLIs read
one type.
"""

from __future__ import annotations

from typing import NamedTuple

#: The verdicts a claim can get: it holds, it does not, it holds in part, or it cannot be judged (data missing).
AGREES = ("yes", "no", "partly", "n/a")


class Verdict(NamedTuple):
    """One judged claim."""

    source: str  #: where the thesis makes it: a figure or table ("3.1", "5.6"), or "" where the context says
    claim: str  #: the claim as the thesis states it
    ours: str  #: what we measured, as shown
    agrees: str  #: one of :data:`AGREES`


def agreement(ok: bool | None) -> str:
    """A test's outcome as a verdict: ``True`` -> ``"yes"``, ``False`` -> ``"no"``, ``None`` (not judged) ->
    ``"n/a"``."""
    return "n/a" if ok is None else ("yes" if ok else "no")
