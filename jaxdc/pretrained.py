"""Trained network parameters as small files: shipped with the package and exported from runs.

One parameter file is a single ``.msgpack`` (flax serialization of the
parameter pytree) with a JSON sidecar ``.json`` of metadata: at least the
network name (``"net"``) and the problem (``"problem"``: ``"dcp"`` or
``"dcg"``), plus whatever the writer needs to rebuild the environment and to
say how the file was made (settings, steps, seed, the command that made it).

The shipped files live in ``jaxdc/assets/<problem>/<name>.msgpack``;
:func:`shipped` finds one by name. :func:`load` checks the metadata against
what the caller expects and raises a ``ValueError`` naming the mismatch, so a
DCG file is never applied to a DCP network, nor an ENN file to EQN.
"""

from __future__ import annotations

import json
import os

import jax
import numpy as np
from flax import serialization

from jaxdc.io import atomic_write, atomic_write_json

ASSETS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "assets")


def _paths(path) -> tuple[str, str]:
    path = os.fspath(path)
    stem = path[: -len(".msgpack")] if path.endswith(".msgpack") else path
    return stem + ".msgpack", stem + ".json"


def save(path, params, metadata: dict) -> str:
    """Write ``params`` and ``metadata`` (JSON-able; must name ``net`` and ``problem``) atomically.

    Returns the ``.msgpack`` path. The sidecar is written after the parameters,
    so a file pair whose sidecar exists is complete.
    """
    for key in ("net", "problem"):
        if key not in metadata:
            raise ValueError(f"metadata must contain {key!r}, got keys {sorted(metadata)}")
    blob, meta = _paths(path)
    tree = jax.tree_util.tree_map(np.asarray, jax.device_get(params))
    atomic_write(blob, serialization.msgpack_serialize(serialization.to_state_dict(tree)))
    atomic_write_json(meta, dict(metadata))
    return blob


def read_metadata(path) -> dict:
    """The metadata sidecar of the parameter file ``path``."""
    blob, meta = _paths(path)
    if not os.path.isfile(meta):
        raise ValueError(f"parameter file {blob}: metadata {meta} not found (was it written by jaxdc.pretrained.save?)")
    try:
        with open(meta) as f:
            return json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(f"parameter file {blob}: metadata {meta} unreadable: {e}") from e


def load(path, **expected) -> tuple[dict, dict]:
    """``(params, metadata)`` of the parameter file ``path``.

    Every keyword of ``expected`` (e.g. ``net="enn", problem="dcp"``) must equal
    the stored metadata entry, else a ``ValueError`` names the key and both values.
    """
    blob, _ = _paths(path)
    meta = read_metadata(path)
    for key, want in expected.items():
        if meta.get(key) != want:
            raise ValueError(f"parameter file {blob} has {key}={meta.get(key)!r}, expected {want!r}")
    try:
        with open(blob, "rb") as f:
            params = serialization.msgpack_restore(f.read())
    except Exception as e:  # msgpack raises several types on a damaged file
        raise ValueError(f"parameter file {blob} unreadable (corrupt or truncated?): {e}") from e
    return params, meta


def shipped(problem: str, name: str) -> str:
    """Path of the shipped parameter file ``name`` of ``problem`` (``jaxdc/assets/<problem>/<name>.msgpack``)."""
    folder = os.path.join(ASSETS, problem)
    path = os.path.join(folder, name + ".msgpack")
    if not os.path.isfile(path):
        have = sorted(f[: -len(".msgpack")] for f in os.listdir(folder) if f.endswith(".msgpack")) \
            if os.path.isdir(folder) else []
        raise ValueError(f"no shipped {problem} parameters named {name!r}; available: {have}")
    return path
