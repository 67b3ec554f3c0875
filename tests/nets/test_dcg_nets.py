"""The DCG networks of section 5.4: shapes, VNN's input, EMNN's alpha, OMN's isolation from CoNN's loss."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.agents.a2c import A2CConfig, a2c_loss, aux_cross_entropy
from jaxdc.nets import DCG_NETS, EMNN, IMNN, VNN, OMNCoNN, make_dcg_net

B, N, K = 3, 5, 4


def _obs(seed=0, k=K):
    return jax.random.normal(jax.random.PRNGKey(seed), (B, N, N, 2 + k))


@pytest.fixture(scope="module")
def nets():
    obs = _obs()
    return {name: (make_dcg_net(name, K), make_dcg_net(name, K).init(jax.random.PRNGKey(1), obs)) for name in DCG_NETS}


def test_registry_and_output_shapes(nets):
    assert set(DCG_NETS) == {"vnn", "imnn", "emnn", "omn_conn"}
    types = {"vnn": VNN, "imnn": IMNN, "emnn": EMNN, "omn_conn": OMNCoNN}
    obs = _obs(2)
    for name, (net, params) in nets.items():
        assert type(net) is types[name] and not net.uses_heuristics and net.num_actions == 9
        out = net.apply(params, obs)
        assert [o.shape for o in out] == ([(B, 9), (B,), (B, 9)] if name in ("emnn", "omn_conn") else [(B, 9), (B,)])
        assert getattr(net, "has_aux", False) == (name in ("emnn", "omn_conn"))
        np.testing.assert_allclose(net.apply(params, obs, method="value"), out[1], rtol=1e-6, atol=1e-6)


def test_vnn_ignores_the_history_channels(nets):
    net, params = nets["vnn"]
    obs = _obs(3)
    changed = obs.at[..., 2:].set(jax.random.normal(jax.random.PRNGKey(9), obs[..., 2:].shape))
    for a, b in zip(net.apply(params, obs), net.apply(params, changed)):
        np.testing.assert_array_equal(a, b)
    net_i, params_i = nets["imnn"]  # IMNN reads them
    assert not np.allclose(net_i.apply(params_i, obs)[0], net_i.apply(params_i, changed)[0])
    assert net.apply(params, obs[..., :2])[0].shape == (B, 9)  # and works on the two planes alone


def test_history_nets_check_k_and_the_registry_validates():
    with pytest.raises(ValueError, match="net must be one of"):
        make_dcg_net("cnn")
    for name in ("imnn", "emnn", "omn_conn"):
        with pytest.raises(ValueError, match=r"history \(k\) must be an int >= 1"):
            make_dcg_net(name, 0)
        with pytest.raises(ValueError, match=r"expects observations \[B, N, N, 6\]"):
            make_dcg_net(name, K).init(jax.random.PRNGKey(0), _obs(k=K + 1))
    assert isinstance(make_dcg_net("vnn", 0), VNN)  # VNN has no history


def _batch(seed=4):
    k1, k2, k3 = jax.random.split(jax.random.PRNGKey(seed), 3)
    return (_obs(seed), jnp.zeros((B, 1, 9)), jax.random.randint(k1, (B,), 0, 9),
            jax.random.normal(k2, (B,)), jax.random.randint(k3, (B,), 0, 9))


def test_emnn_auxiliary_loss_is_weighted_by_alpha(nets):
    net, params = nets["emnn"]
    obs, h, actions, returns, targets = _batch()
    ce, _ = aux_cross_entropy(net.apply(params, obs)[2], targets)
    base, m0 = a2c_loss(params, net.apply, obs, h, actions, returns, A2CConfig(aux_coef=0.0), targets)
    grads = {}
    for alpha in (0.001, 0.0001):
        loss, m = a2c_loss(params, net.apply, obs, h, actions, returns, A2CConfig(aux_coef=alpha), targets)
        np.testing.assert_allclose(loss - base, alpha * ce, rtol=1e-4)
        np.testing.assert_allclose(m["aux_loss"], ce, rtol=1e-6)
        grads[alpha] = jax.grad(lambda p, a=alpha: a2c_loss(p, net.apply, obs, h, actions, returns,
                                                            A2CConfig(aux_coef=a), targets)[0])(params)
    # the opponent head learns only from the alpha-weighted cross-entropy: its gradient scales with alpha
    g1, g2 = (grads[a]["params"]["opponent_out"]["kernel"] for a in (0.001, 0.0001))
    assert np.abs(g1).max() > 0
    np.testing.assert_allclose(g1, 10 * g2, rtol=1e-3, atol=1e-12)


def _norms(tree):
    return [float(jnp.abs(x).max()) for x in jax.tree_util.tree_leaves(tree)]


def test_omn_gets_no_gradient_from_the_policy_and_value_loss(nets):
    net, params = nets["omn_conn"]
    obs, h, actions, returns, targets = _batch(5)
    ac_only = A2CConfig(aux_coef=0.0)  # policy + value + entropy terms of CoNN
    g = jax.grad(lambda p: a2c_loss(p, net.apply, obs, h, actions, returns, ac_only, targets)[0])(params)["params"]
    assert max(_norms(g["omn"])) == 0.0
    assert max(_norms(g["conn"])) > 0.0
    # and OMN's cross-entropy trains OMN alone
    g_ce = jax.grad(lambda p: aux_cross_entropy(net.apply(p, obs)[2], targets)[0])(params)["params"]
    assert max(_norms(g_ce["conn"])) == 0.0 and max(_norms(g_ce["omn"])) > 0.0


def test_omn_lr_applies_to_omns_parameters_only(nets):
    """A2CConfig.aux_lr (train.dcg --omn-lr, not in the thesis): OMN's own Adam; CoNN's updates are unchanged."""
    from jaxdc.agents.a2c import make_optimizer

    net, params = nets["omn_conn"]
    obs, h, actions, returns, targets = _batch(7)
    cfg = A2CConfig(total_steps=32 * 16 * 10)
    grad = jax.jit(jax.grad(lambda p: a2c_loss(p, net.apply, obs, h, actions, returns, cfg, targets)[0]))

    def steps(tx, n=3):
        p, state = params, tx.init(params)
        deltas = []
        for _ in range(n):
            u, state = tx.update(grad(p), state, p)
            deltas.append(u)
            p = jax.tree_util.tree_map(lambda a, b: a + b, p, u)
        return deltas

    base = steps(make_optimizer(cfg))
    same = steps(make_optimizer(A2CConfig(total_steps=cfg.total_steps, aux_lr=cfg.lr), net.aux_params))
    for a, b in zip(jax.tree_util.tree_leaves(base), jax.tree_util.tree_leaves(same)):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-12)  # aux_lr == lr: the single Adam exactly
    fast = make_optimizer(A2CConfig(total_steps=cfg.total_steps, aux_lr=100 * cfg.lr), net.aux_params)
    first = steps(fast, 1)[0]["params"]
    for a, b in zip(jax.tree_util.tree_leaves(base[0]["params"]["conn"]), jax.tree_util.tree_leaves(first["conn"])):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-12)  # CoNN: the same step
    moved = [(a, b) for a, b in zip(jax.tree_util.tree_leaves(base[0]["params"]["omn"]),
                                    jax.tree_util.tree_leaves(first["omn"])) if np.abs(a).max() > 0]
    assert moved
    for a, b in moved:  # Adam's first step is lr * sign(g): OMN's is 100 times larger
        np.testing.assert_allclose(b, 100 * a, rtol=1e-4, atol=1e-10)
    with pytest.raises(ValueError, match="aux_lr"):
        A2CConfig(aux_lr=0.0)
    with pytest.raises(ValueError, match="aux_lr"):
        make_optimizer(A2CConfig(aux_lr=1e-3))  # no aux_params
    with pytest.raises(ValueError, match="no parameters named"):
        make_optimizer(A2CConfig(aux_lr=1e-3), ("nope",)).init(params)


def test_conn_reads_omns_prediction(nets):
    net, params = nets["omn_conn"]
    obs = _obs(6)
    other = jax.tree_util.tree_map(lambda x: x, params)
    other["params"]["omn"]["opponent_out"]["bias"] = params["params"]["omn"]["opponent_out"]["bias"] + jnp.arange(9.0)
    assert not np.allclose(net.apply(params, obs)[0], net.apply(other, obs)[0])


@pytest.mark.parametrize("name", ["vnn", "imnn", "emnn", "emnn_alpha1e-4", "omn_conn", "omn_conn_envs1"])
def test_shipped_parameters_fit_their_network(name):
    """jaxdc/assets/dcg: every shipped file loads into make_dcg_net(net, history) for the standard setting."""
    from jaxdc import pretrained

    params, meta = pretrained.load(pretrained.shipped("dcg", name), problem="dcg")
    assert meta["grid_size"] == 5 and meta["total_reward"] == 10 and meta["energy"] == 15.0
    assert meta["strategies"] == ["patrol", "restricted", "with_fog"] and meta["steps"] == 1_000_000
    assert meta["history"] == (0 if meta["net"] == "vnn" else 10) and meta["command"].startswith("python -m train.dcg")
    net = make_dcg_net(meta["net"], meta["history"])
    out = net.apply(params, jnp.zeros((2, 5, 5, 2 + meta["history"])))
    assert out[0].shape == (2, 9) and bool(jnp.all(jnp.isfinite(out[0])))


#: Name suffix of a shipped DCG file trained outside the standard setting -> the metadata it must record.
VARIANTS = {"_energy10": {"energy": 10.0}, "_energy20": {"energy": 20.0}, "_5m": {"steps": 5_000_000},
            "_double_blind": {"strategies": ["patrol", "restricted", "double_blind"]},
            # beyond the thesis: trained on one unit item in the bottom-right S x S reward area (docs/dcg.md)
            **{f"_area{s}": {"reward_area": s, "total_reward": 1, "steps": 10_000_000} for s in (2, 3, 4)}}


def test_shipped_variants_record_the_setting_their_name_says():
    """The retrained networks of Figs. 5.8/5.9 (energy), 5.16/5.17 (5M steps), 5.18/5.19 (double blind), and the
    one-item networks of the reward-area experiment."""
    from jaxdc import pretrained

    standard = {"energy": 15.0, "steps": 1_000_000, "strategies": ["patrol", "restricted", "with_fog"],
                "total_reward": 10}
    seen = 0
    for name in pretrained.shipped_names("dcg"):
        suffix = next((s for s in VARIANTS if name.endswith(s)), None)
        if suffix is None:
            continue
        seen += 1
        params, meta = pretrained.load(pretrained.shipped("dcg", name), problem="dcg")
        assert name.startswith(meta["net"] + "_"), name
        for key, value in {**standard, **VARIANTS[suffix]}.items():
            assert meta[key] == value, (name, key, meta[key])
        net = make_dcg_net(meta["net"], meta["history"])
        out = net.apply(params, jnp.zeros((1, 5, 5, 2 + meta["history"])))
        assert out[0].shape == (1, 9) and bool(jnp.all(jnp.isfinite(out[0]))), name
    assert seen >= 18, seen
