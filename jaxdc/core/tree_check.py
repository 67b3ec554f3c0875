"""Check that loaded parameters fit a network, with an error that says what does not.

A parameter file or checkpoint may hold another network, or the right
network trained on another grid or history length. Applying it would fail
deep inside flax (or, worse, broadcast silently); :func:`check_like` compares
the loaded pytree with freshly initialised parameters first. :func:`mismatch`
is the comparison itself, which :mod:`jaxdc.checkpoint` also uses on a
restored training state; :func:`non_finite` finds the float leaves that hold a
NaN or an infinity (a parameter file or checkpoint must hold none); :func:`digest` fingerprints a pytree's
arrays (a checkpoint's integrity check, the record of the network a run started from).
"""

from __future__ import annotations

import hashlib
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np


class Mismatch(NamedTuple):
    """How a pytree differs from a template: leaf paths missing or unexpected, or the first leaf of another shape."""

    missing: list  # sorted paths of the template that the tree lacks
    unexpected: list  # sorted paths of the tree that the template lacks
    key: str | None = None  # with the same paths: the first (in the template's order) whose shape differs
    got: tuple = ()
    want: tuple = ()


def mismatch(template: Any, tree: Any, key: Callable = jax.tree_util.keystr) -> Mismatch | None:
    """``None`` if ``tree`` has ``template``'s leaf paths and shapes, else the :class:`Mismatch`.

    ``key`` turns a leaf's path (``jax.tree_util`` path entries) into its name.
    """
    want = {key(k): np.shape(v) for k, v in jax.tree_util.tree_flatten_with_path(template)[0]}
    got = {key(k): np.shape(v) for k, v in jax.tree_util.tree_flatten_with_path(tree)[0]}
    if want.keys() != got.keys():
        return Mismatch(sorted(set(want) - set(got)), sorted(set(got) - set(want)))
    for k, shape in want.items():
        if got[k] != shape:
            return Mismatch([], [], k, got[k], shape)
    return None


def slash_path(path: Any) -> str:
    """A leaf's path (``jax.tree_util`` path entries) as ``/key/key`` (attributes by name, list entries by index)."""
    return "".join(f"/{getattr(k, 'key', getattr(k, 'name', getattr(k, 'idx', k)))}" for k in path)


def non_finite(tree: Any, key: Callable = jax.tree_util.keystr) -> list[tuple[str, int]]:
    """``(name, count)`` of each float leaf of ``tree`` holding NaN or infinite values, in the tree's order
    (traced leaves, inside a jit, are skipped: they are checked where their values are known)."""
    out = []
    for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
        if isinstance(leaf, jax.core.Tracer):
            continue
        a = np.asarray(leaf)
        if np.issubdtype(a.dtype, np.inexact):
            bad = int(a.size - np.count_nonzero(np.isfinite(a)))
            if bad:
                out.append((key(path), bad))
    return out


def check_like(template: Any, params: Any, source: str, what: str, hint: str = "") -> Any:
    """``params`` as float32 arrays if it has exactly ``template``'s structure and shapes, else ``ValueError``.

    ``source`` names the file, ``what`` the network (e.g. ``"a omn_conn network
    with history 10 on a 5x5 grid"``) and ``hint`` is appended to a shape
    mismatch (e.g. what may have differed in training).
    """
    m = mismatch(template, params)
    if m is not None and m.key is None:
        raise ValueError(f"{source}: the parameters are not those of {what} "
                         f"(missing {m.missing[:3]}, unexpected {m.unexpected[:3]})")
    if m is not None:
        raise ValueError(f"{source}: parameter {m.key} has shape {m.got}, expected {m.want} for {what}"
                         + (f" ({hint})" if hint else ""))
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, jnp.float32), params)


def digest(tree: Any) -> str:
    """SHA-256 of a pytree's arrays (path, dtype, shape and bytes of each leaf, in the tree's order)."""
    h = hashlib.sha256()
    for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
        a = np.ascontiguousarray(np.asarray(leaf))
        h.update(f"{slash_path(path)}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()
