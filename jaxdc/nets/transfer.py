"""Start a network from another's parameters when its observation gains planes (beyond the thesis).

A network trained on one observation can seed a network of the same kind whose observation has ``extra`` more
planes inserted at channel ``at`` -- e.g. a one-collector DCG network seeding a team network, whose observation
has the teammates plane after ``M^agent`` (:mod:`jaxdc.dcg.team.observation`). :func:`widen_inputs` copies
every parameter and gives each layer that reads the observation zero weights on the new planes, so that the
widened network computes exactly what the source computes, whatever the new planes hold: training starts from
the source's behaviour (for a team, from :func:`jaxdc.dcg.team.policies.copies` of the source) and learns what
the new planes are worth.

The rule is by shape, the same for every network: a parameter whose shape equals the target's is copied; one
that differs only on its input axis (the second-to-last: a convolution kernel's ``HWIO`` input channels, a
dense kernel's input features), and there by exactly ``extra``, gets ``extra`` zero rows inserted at ``at``; any
other difference is refused. A layer that reads the observation flattened (e.g. the linear learner's dense
layer) differs by ``N * N * extra`` and is refused.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core.validate import check_int


def widen_inputs(params: Any, template: Any, at: int, extra: int, source: str = "params") -> Any:
    """``params`` with ``extra`` zero input planes inserted at channel ``at`` of every layer that reads them.

    ``template`` is the widened network's parameters (e.g. freshly initialised; only its structure and shapes are
    read). Returns float32 arrays with ``template``'s structure. A ``ValueError`` names ``source`` and the first
    parameter that neither matches nor widens (module docs).
    """
    check_int("at", at, 0, None)
    check_int("extra", extra, 0, None)
    want = {jax.tree_util.keystr(k): v for k, v in jax.tree_util.tree_flatten_with_path(template)[0]}
    got = {jax.tree_util.keystr(k): v for k, v in jax.tree_util.tree_flatten_with_path(params)[0]}
    if want.keys() != got.keys():
        raise ValueError(f"{source}: not the parameters of the same network (missing "
                         f"{sorted(set(want) - set(got))[:3]}, unexpected {sorted(set(got) - set(want))[:3]})")

    def widen(key: str, leaf: Any, shape: tuple) -> jax.Array:
        a = np.asarray(leaf, np.float32)
        if a.shape == shape:
            return jnp.asarray(a)
        same_elsewhere = a.ndim == len(shape) >= 2 and a.shape[:-2] + a.shape[-1:] == shape[:-2] + shape[-1:]
        if not same_elsewhere or shape[-2] - a.shape[-2] != extra or at > a.shape[-2]:
            raise ValueError(f"{source}: parameter {key} has shape {a.shape}; the widened network's has {shape}, "
                             f"which is not {extra} more input planes at channel {at}")
        zeros = np.zeros(a.shape[:-2] + (extra, a.shape[-1]), np.float32)
        return jnp.asarray(np.concatenate([a[..., :at, :], zeros, a[..., at:, :]], axis=-2))

    leaves, treedef = jax.tree_util.tree_flatten_with_path(template)
    return jax.tree_util.tree_unflatten(
        treedef, [widen(jax.tree_util.keystr(k), got[jax.tree_util.keystr(k)], tuple(v.shape)) for k, v in leaves])
