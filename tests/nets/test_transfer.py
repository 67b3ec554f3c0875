"""jaxdc.nets.transfer.widen_inputs: a network widened by zero-weighted input planes computes what its source
computes, whatever the new planes hold; anything but "the same network with more input planes" is refused."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.nets import build
from jaxdc.nets.transfer import widen_inputs

N, K = 4, 2


def _init(net, channels, seed=0):
    return jax.jit(net.init)(jax.random.PRNGKey(seed), jnp.zeros((1, N, N, channels)), jnp.zeros((1, 1, 9)))


@pytest.mark.parametrize("name", ["vnn", "imnn", "emnn", "omn_conn"])
def test_the_widened_network_computes_the_source_on_any_new_plane(name):
    source_net = build("dcg", name, history=K, state_channels=2)
    wide_net = build("dcg", name, history=K, state_channels=3)
    source = _init(source_net, 2 + K)
    wide = widen_inputs(source, _init(wide_net, 3 + K, seed=1), at=2, extra=1)
    obs = jax.random.uniform(jax.random.PRNGKey(2), (8, N, N, 2 + K), minval=-1.0, maxval=1.0)
    plane = jax.random.uniform(jax.random.PRNGKey(3), (8, N, N, 1), minval=-5.0, maxval=5.0)
    wide_obs = jnp.concatenate([obs[..., :2], plane, obs[..., 2:]], axis=-1)
    for a, b in zip(source_net.apply(source, obs), wide_net.apply(wide, wide_obs)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-6, atol=1e-6)
    # every widened layer is the source's with a zero row at channel 2; the template's values are not used
    pairs = [(a, b) for a, b in zip(jax.tree_util.tree_leaves(source), jax.tree_util.tree_leaves(wide))
             if a.shape != b.shape]
    assert pairs
    for a, b in pairs:
        np.testing.assert_array_equal(np.asarray(b), np.insert(np.asarray(a), 2, 0.0, axis=-2))


def test_equal_shapes_are_copied():
    net = build("dcg", "omn_conn", history=K)
    source = _init(net, 2 + K)
    out = widen_inputs(source, _init(net, 2 + K, seed=5), at=2, extra=0)
    for a, b in zip(jax.tree_util.tree_leaves(source), jax.tree_util.tree_leaves(out)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_another_network_or_another_widening_is_refused():
    omn = _init(build("dcg", "omn_conn", history=K), 2 + K)
    wide = _init(build("dcg", "omn_conn", history=K, state_channels=3), 3 + K)
    with pytest.raises(ValueError, match="src: not the parameters of the same network"):
        widen_inputs(_init(build("dcg", "vnn", history=K), 2 + K), wide, at=2, extra=1, source="src")
    with pytest.raises(ValueError, match=r"src: parameter .* is not 2 more input planes at channel 2"):
        widen_inputs(omn, wide, at=2, extra=2, source="src")
    with pytest.raises(ValueError, match="at must be"):
        widen_inputs(omn, wide, at=-1, extra=1)


def test_a_layer_reading_the_flattened_observation_is_refused():
    """The linear learner's dense layer reads N*N*C inputs: one more plane is N*N more, not one."""
    net = build("dcp", "linear")
    small = jax.jit(net.init)(jax.random.PRNGKey(0), jnp.zeros((1, N, N, 2)), jnp.zeros((1, 10, 9)))
    big = jax.jit(net.init)(jax.random.PRNGKey(0), jnp.zeros((1, N, N, 3)), jnp.zeros((1, 10, 9)))
    with pytest.raises(ValueError, match="not 1 more input planes"):
        widen_inputs(small, big, at=2, extra=1)
