"""The Flax networks of jaxdc.nets: shapes, the ENN ensemble of Fig. 4.3, heuristics ignored where they should be."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.nets import ACTOR_CRITICS, ENN, make_net

B, N = 3, 5


def _inputs(seed=0):
    k1, k2 = jax.random.split(jax.random.PRNGKey(seed))
    obs = jax.random.uniform(k1, (B, N, N, 2)) * 4
    heur = jax.random.uniform(k2, (B, 10, 9))
    return obs, heur


@pytest.mark.parametrize("name", sorted(ACTOR_CRITICS))
def test_shapes_and_value_method(name):
    net = make_net(name)
    obs, heur = _inputs()
    params = net.init(jax.random.PRNGKey(0), obs, heur)
    logits, value = net.apply(params, obs, heur)
    assert logits.shape == (B, 9) and value.shape == (B,)
    assert np.all(np.isfinite(logits)) and np.all(np.isfinite(value))
    np.testing.assert_allclose(net.apply(params, obs, method="value"), value, rtol=1e-6, atol=1e-6)


def test_body_sizes_follow_section_4_5():
    params = make_net("enn").init(jax.random.PRNGKey(0), *_inputs())["params"]
    body = params["body"]
    assert body["Conv_0"]["kernel"].shape == (3, 3, 2, 32)
    assert body["Conv_1"]["kernel"].shape == (3, 3, 32, 16)
    assert body["Dense_0"]["kernel"].shape == (N * N * 16, 256)


def test_enn_logits_are_the_weighted_sum_of_heuristics():
    net = ENN()
    obs, heur = _inputs()
    params = net.init(jax.random.PRNGKey(1), obs, heur)
    (logits, _), inter = net.apply(params, obs, heur, mutable=["intermediates"])
    w = inter["intermediates"]["head"]["w"][0]
    b = inter["intermediates"]["head"]["b"][0]
    assert w.shape == (B, 10, 9) and b.shape == (B, 9)
    expected = np.einsum("bia,bia->ba", np.asarray(w), np.asarray(heur)) + np.asarray(b)
    np.testing.assert_allclose(np.asarray(logits), expected, rtol=1e-5, atol=1e-5)
    # the heuristics matter: changing one row changes the logits by w_i * delta
    heur2 = heur.at[:, 3].add(1.0)
    logits2, _ = net.apply(params, obs, heur2)
    np.testing.assert_allclose(np.asarray(logits2 - logits), np.asarray(w[:, 3]), rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name", ["linear", "cnn"])
def test_heuristic_free_nets_ignore_heuristics(name):
    net = make_net(name)
    obs, heur = _inputs()
    params = net.init(jax.random.PRNGKey(0), obs, heur)
    a = net.apply(params, obs, heur)
    b = net.apply(params, obs, jnp.zeros_like(heur))
    np.testing.assert_array_equal(np.asarray(a[0]), np.asarray(b[0]))
    assert not net.uses_heuristics and make_net("enn").uses_heuristics


def test_linear_is_linear_in_the_planes():
    net = make_net("linear")
    obs, heur = _inputs()
    params = net.init(jax.random.PRNGKey(0), obs, heur)
    zero = jnp.zeros_like(obs)
    f = lambda x: net.apply(params, x, heur)[0]  # noqa: E731
    np.testing.assert_allclose(f(2 * obs) - f(zero), 2 * (f(obs) - f(zero)), rtol=1e-4, atol=1e-4)


def test_unknown_net():
    with pytest.raises(ValueError, match="net must be one of"):
        make_net("eqn2")


def test_eqn_q_values_are_the_weighted_sum_of_heuristics():
    from jaxdc.nets import EQN

    net = EQN()
    obs, heur = _inputs(2)
    params = net.init(jax.random.PRNGKey(0), obs, heur)
    q, inter = net.apply(params, obs, heur, mutable=["intermediates"])
    w = np.asarray(inter["intermediates"]["head"]["w"][0])
    b = np.asarray(inter["intermediates"]["head"]["b"][0])
    assert q.shape == (B, 9)
    np.testing.assert_allclose(np.asarray(q), np.einsum("bia,bia->ba", w, np.asarray(heur)) + b, rtol=1e-5, atol=1e-5)
    assert "value_out" not in params["params"]


def test_every_network_declares_the_trainer_contract():
    """The attributes a trainer reads (jaxdc.agents.common.Network) are declared by every network, not flax fields."""
    from jaxdc.agents.common import Network, check_network
    from jaxdc.nets import EQN, make_dcg_net, make_net

    nets = [make_net(n) for n in ("enn", "linear", "cnn")] + [EQN()] + [make_dcg_net(n) for n in
                                                                       ("vnn", "imnn", "emnn", "omn_conn")]
    for net in nets:
        assert isinstance(net, Network) and check_network(net) is net
        assert isinstance(net.uses_heuristics, bool) and isinstance(net.has_aux, bool)
        assert isinstance(net.aux_params, tuple) and isinstance(net.num_actions, int)
    with pytest.raises(TypeError, match="lacks"):
        check_network(object())


def test_a_wider_body_is_an_option_and_the_default_is_the_thesis_body():
    """``build(..., body_features, body_hidden)`` (beyond the thesis) sizes ENN's, EQN's and the CNN's body; unset, the
    parameters are exactly those of section 4.5."""
    from jaxdc.nets import build

    obs, heur = _inputs()
    for name in ("enn", "eqn", "cnn"):
        net = build("dcp", name, body_features=(8, 8, 4), body_hidden=24)
        wide = net.init(jax.random.PRNGKey(0), obs, heur)["params"]
        assert wide["body"]["Conv_2"]["kernel"].shape == (3, 3, 8, 4), name
        assert wide["body"]["Dense_0"]["kernel"].shape == (N * N * 4, 24), name
        plain = jax.tree_util.tree_map(jnp.shape, build("dcp", name).init(jax.random.PRNGKey(0), obs, heur))
        thesis = build("dcp", name, body_features=(32, 16), body_hidden=256).init(jax.random.PRNGKey(0), obs, heur)
        assert plain == jax.tree_util.tree_map(jnp.shape, thesis), name
    only_hidden = build("dcp", "enn", body_hidden=64).init(jax.random.PRNGKey(0), obs, heur)["params"]["body"]
    assert only_hidden["Conv_1"]["kernel"].shape == (3, 3, 32, 16) and only_hidden["Dense_0"]["kernel"].shape[1] == 64


@pytest.mark.parametrize(("name", "features", "hidden", "error", "match"), [
    ("linear", None, 64, ValueError, "body_hidden=64: network 'linear' has no convolutional body"),
    ("vnn", (8,), None, ValueError, "network 'vnn' has no convolutional body"),
    ("enn", (), None, ValueError, r"body_features must hold 1..6 filter counts, got 0"),
    ("enn", (1,) * 7, None, ValueError, r"body_features must hold 1..6 filter counts, got 7"),
    ("enn", (8, 0), None, ValueError, r"body_features\[1\] must be in \[1, 4096\], got 0"),
    ("enn", (8, 2.5), None, TypeError, r"body_features\[1\] must be an int"),
    ("enn", "64", None, TypeError, "body_features must be a sequence"),
    ("enn", None, 5000, ValueError, r"body_hidden must be in \[1, 4096\], got 5000"),
    ("enn", None, True, TypeError, "body_hidden must be an int"),
])
def test_a_bad_body_is_refused_by_name(name, features, hidden, error, match):
    from jaxdc.nets import build

    problem = "dcg" if name == "vnn" else "dcp"
    with pytest.raises(error, match=match):
        build(problem, name, body_features=features, body_hidden=hidden)


def test_a_pooled_body_fits_every_grid_size_and_a_bad_pool_is_refused():
    """``body_pool="mean_max"`` (beyond the thesis) pools the last convolutional layer over the cells: the
    parameters have the same shapes on every grid size and play each; the thesis' flattened body's do not."""
    from jaxdc.nets import build

    net = build("dcp", "enn", body_pool="mean_max")
    heur = jnp.zeros((2, 10, 9))
    shapes = {n: jax.tree_util.tree_map(jnp.shape, net.init(jax.random.PRNGKey(0), jnp.zeros((2, n, n, 2)), heur))
              for n in (4, 9)}
    assert shapes[4] == shapes[9]
    params = net.init(jax.random.PRNGKey(0), jnp.zeros((2, 4, 4, 2)), heur)
    obs = jax.random.uniform(jax.random.PRNGKey(1), (2, 9, 9, 2))
    logits, value = net.apply(params, obs, heur)
    assert logits.shape == (2, 9) and value.shape == (2,) and bool(jnp.all(jnp.isfinite(logits)))
    flat = build("dcp", "enn")
    assert (jax.tree_util.tree_map(jnp.shape, flat.init(jax.random.PRNGKey(0), jnp.zeros((2, 4, 4, 2)), heur))
            != jax.tree_util.tree_map(jnp.shape, flat.init(jax.random.PRNGKey(0), jnp.zeros((2, 9, 9, 2)), heur)))
    for bad in ("avg", "", "MEAN_MAX"):
        with pytest.raises(ValueError, match=r"body_pool must be one of \('flatten', 'mean_max'\)"):
            build("dcp", "cnn", body_pool=bad)
    with pytest.raises(ValueError, match="body_pool='mean_max': network 'linear' has no convolutional body"):
        build("dcp", "linear", body_pool="mean_max")
