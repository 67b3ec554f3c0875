"""Check that loaded parameters fit a network, with an error that says what does not.

A parameter file or checkpoint may hold another network, or the right
network trained on another grid or history length. Applying it would fail
deep inside flax (or, worse, broadcast silently); :func:`check_like` compares
the loaded pytree with freshly initialised parameters first.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np


def check_like(template, params, source: str, what: str, hint: str = ""):
    """``params`` as float32 arrays if it has exactly ``template``'s structure and shapes, else ``ValueError``.

    ``source`` names the file, ``what`` the network (e.g. ``"a omn_conn network
    with history 10 on a 5x5 grid"``) and ``hint`` is appended to a shape
    mismatch (e.g. what may have differed in training).
    """
    want = {jax.tree_util.keystr(k): np.shape(v) for k, v in jax.tree_util.tree_flatten_with_path(template)[0]}
    got = {jax.tree_util.keystr(k): np.shape(v) for k, v in jax.tree_util.tree_flatten_with_path(params)[0]}
    if want.keys() != got.keys():
        raise ValueError(f"{source}: the parameters are not those of {what} "
                         f"(missing {sorted(set(want) - set(got))[:3]}, unexpected {sorted(set(got) - set(want))[:3]})")
    for k, shape in want.items():
        if got[k] != shape:
            raise ValueError(f"{source}: parameter {k} has shape {got[k]}, expected {shape} for {what}"
                             + (f" ({hint})" if hint else ""))
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, jnp.float32), params)
