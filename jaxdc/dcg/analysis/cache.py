"""Stored evaluations of the section-5.5 figures: one JSON file per parameter file and settings.

An evaluation of 10,000 games per bar takes minutes; :class:`EvaluationCache`
keeps each result under a digest of the parameter file (its bytes and its
metadata file) and the settings, so a figure re-made with the same networks and
settings reads them instead of playing again. A result of the settings alone
(the sampled full-information bound of a game, which no parameter file
changes) is stored as ``bound_<digest>.json``.

Each stored file also records where its result came from
(:func:`jaxdc.provenance.provenance`, the key ``"provenance"``): a sibling of
the result's fields that :meth:`EvaluationCache.load` leaves out, so a result
read back is the one stored, whichever machine and commit computed it (the
figure that uses it records its own provenance).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from typing import Callable

from jaxdc.core.record_fields import Fields
from jaxdc.io import atomic_write_json, check_output_path, read_json
from jaxdc.provenance import provenance

#: The key of a stored file's provenance, beside the result's own fields (left out by :meth:`EvaluationCache.load`).
PROVENANCE_KEY = "provenance"


@dataclasses.dataclass(frozen=True)
class EvaluationCache:
    """A folder of stored results; ``reuse=False`` never reads them (every result is computed and stored)."""

    folder: str
    reuse: bool = True

    def path(self, blob: str | None, settings: dict) -> str:
        """``<folder>/<sha256>.json``: one result of the parameter file ``blob`` (a ``.msgpack`` path) with
        ``settings``; ``blob=None``: a result of the settings alone (``bound_<sha256>.json``)."""
        digest = hashlib.sha256()
        for path in () if blob is None else (blob, blob[: -len(".msgpack")] + ".json"):
            with open(path, "rb") as f:
                digest.update(f.read())
        digest.update(json.dumps(settings, sort_keys=True, default=list).encode())
        return os.path.join(self.folder, ("bound_" if blob is None else "") + digest.hexdigest()[:24] + ".json")

    def load(self, blob: str | None, settings: dict,
             check: Callable[[Fields, dict], object] | None = None) -> dict | None:
        """The stored result of the same file with the same settings (without its provenance), ``None`` if there
        is none (or no reuse); then the file :meth:`store` will write must be writable (a folder or a dangling
        symbolic link at its name is a ``ValueError`` now, before the evaluation).

        ``check(fields, result)`` (e.g. :func:`jaxdc.dcg.analysis.records.check_evaluation`) checks the result's
        fields; a damaged one is a ``ValueError`` naming the file and the key, and telling to delete it.
        """
        path = self.path(blob, settings)
        if not self.reuse or not os.path.isfile(path):
            # the result will be evaluated, then stored here: a folder or a dangling link at the name is refused now,
            # before the evaluation, not after it
            check_output_path(path, "cache file")
            return None
        hint = "delete it (or pass --no-cache) to evaluate again"
        stored = read_json(path, hint)
        if not isinstance(stored, dict):
            raise ValueError(f"{path}: a cached result must be a JSON object; {hint}")
        stored.pop(PROVENANCE_KEY, None)
        if check is not None:
            check(Fields(path, hint), stored)
        return stored

    def store(self, blob: str | None, settings: dict, result: dict) -> str:
        """Store ``result`` with its provenance (atomically) and return its path."""
        if PROVENANCE_KEY in result:
            raise ValueError(f"result: the key {PROVENANCE_KEY!r} is the stored file's own; got a result holding it")
        return atomic_write_json(self.path(blob, settings), {**result, PROVENANCE_KEY: provenance()})
