"""Warm starts (beyond the thesis): a run that starts from a trained network's parameters instead of a fresh
initialisation (``train.dcp --init-from``, ``train.dcg --init-from``).

The thesis trains every network from scratch. A warm start fine-tunes a network on a new setting (e.g. the general
``enn_general`` on one risk map) or continues a run at another learning rate (docs/generalisation.md, "Continued
training"). What is shared by the problems lives here: the check of the ``init_from`` setting, the comparison of
the source's training setting with the run's, and the two metadata fields (``init_from``, ``init_sha256``) that
record the source and the SHA-256 of its parameters (:func:`jaxdc.core.tree_check.digest`), so that ``--config``
of the run names exactly what it started from. Each problem reads its own source (:func:`jaxdc.dcp.learned.load`,
:func:`jaxdc.dcg.learned.load`) and adapts the parameters where it can (a team: :mod:`jaxdc.nets.transfer`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["check_init_from", "check_same_setting", "init_metadata"]


def check_init_from(value: object) -> None:
    """``TypeError`` unless ``value`` is ``None`` (a fresh initialisation) or a non-empty string (a shipped name, a
    ``.msgpack`` or a run folder)."""
    if value is not None and (not isinstance(value, str) or not value):
        raise TypeError(f"init_from must be a network's name or path (a non-empty string), got {value!r}")


def check_same_setting(where: str, pairs: Mapping[str, tuple[Any, Any]]) -> None:
    """``ValueError`` naming ``where`` (``init_from=... (source)``) at the first ``key: (source's, run's)`` pair
    whose values differ: a network starts only a run of its own kind, grid and observation."""
    for key, (theirs, wanted) in pairs.items():
        if theirs != wanted:
            raise ValueError(f"{where}: its {key} is {theirs!r}; this run's is {wanted!r}")


def init_metadata(init_from: str | None, init_sha256: str | None) -> dict[str, Any]:
    """The run metadata's fields of a warm start (``{}`` without one, so a fresh run's files are unchanged)."""
    return {} if init_from is None else {"init_from": init_from, "init_sha256": init_sha256}
