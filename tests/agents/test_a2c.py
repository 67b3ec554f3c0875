"""Synchronous A2C (jaxdc.agents.a2c): returns, losses, schedule, exact resume, and a tiny run that learns."""

from __future__ import annotations

import dataclasses
import tempfile

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from jaxdc import checkpoint
from jaxdc.agents import a2c
from jaxdc.agents.a2c import A2CConfig, huber, lr_schedule, make_policy, make_train, nstep_returns
from jaxdc.core.paths import safest_paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import summarize
from jaxdc.dcp.navigators import batched_heuristics
from jaxdc.nets import make_net

# A small, low-risk DCP that ENN learns in a few thousand steps.
ENV = DCP(grid_size=4, total_reward=6)
PARAMS = ENV.make_params("low", (4.0, 8.0), max_steps=100)
HEUR = batched_heuristics(PARAMS, safest_paths(PARAMS.risk))


def test_nstep_returns_by_hand():
    gamma = 0.5
    rewards = jnp.array([[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])  # [T=3, B=2]
    terminated = jnp.array([[False, True], [False, False], [False, False]])
    truncated = jnp.array([[False, False], [False, True], [False, False]])
    final_values = jnp.array([[0.0, 0.0], [0.0, 10.0], [0.0, 0.0]])
    last_value = jnp.array([4.0, 8.0])
    got = nstep_returns(rewards, terminated, truncated, final_values, last_value, gamma)
    # env 0 never ends: R2 = 3 + .5*4 = 5, R1 = 2 + .5*5 = 4.5, R0 = 1 + .5*4.5 = 3.25
    # env 1: R2 = 1 + .5*8 = 5; step 1 truncated -> bootstrap V(final obs) = 10: R1 = 6;
    #        step 0 terminal -> no bootstrap: R0 = 1
    np.testing.assert_allclose(np.asarray(got), [[3.25, 1.0], [4.5, 6.0], [5.0, 5.0]])


def test_lambda_returns_by_hand_and_lambda_one_is_nstep():
    gamma, lam = 0.5, 0.5
    rewards = jnp.array([[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])
    terminated = jnp.array([[False, True], [False, False], [False, False]])
    truncated = jnp.array([[False, False], [False, True], [False, False]])
    final_values = jnp.array([[0.0, 0.0], [0.0, 10.0], [0.0, 0.0]])
    values = jnp.array([[2.0, 2.0], [6.0, 2.0], [4.0, 2.0]])
    last_value = jnp.array([4.0, 8.0])
    got = nstep_returns(rewards, terminated, truncated, final_values, last_value, gamma, values, lam)
    # env 0: G2 = 3 + .5*4 = 5; G1 = 2 + .5*(.5*V(s2)=4*.5 + .5*G2) = 2 + .5*(2 + 2.5) = 4.25
    #        G0 = 1 + .5*(.5*6 + .5*4.25) = 1 + .5*5.125 = 3.5625
    # env 1: G2 = 1 + .5*8 = 5; truncated at 1: G1 = 1 + .5*10 = 6; terminal at 0: G0 = 1
    np.testing.assert_allclose(np.asarray(got), [[3.5625, 1.0], [4.25, 6.0], [5.0, 5.0]])
    full = nstep_returns(rewards, terminated, truncated, final_values, last_value, gamma, values, 1.0)
    np.testing.assert_array_equal(np.asarray(full), np.asarray(
        nstep_returns(rewards, terminated, truncated, final_values, last_value, gamma)))
    with pytest.raises(ValueError, match="values"):
        nstep_returns(rewards, terminated, truncated, final_values, last_value, gamma, None, 0.9)


def test_ppo_clipping_cuts_the_gradient_outside_the_trust_region():
    """With clip_eps, a sample whose ratio is already beyond 1 + eps (positive advantage) gives no policy gradient."""
    from jaxdc.agents.a2c import a2c_loss

    net = make_net("linear")
    obs = jax.random.uniform(jax.random.PRNGKey(0), (6, 4, 4, 2))
    params = net.init(jax.random.PRNGKey(1), obs, None)
    actions = jnp.arange(6, dtype=jnp.int32)
    logp = jax.nn.log_softmax(net.apply(params, obs, None)[0])
    logp_a = jnp.take_along_axis(logp, actions[:, None], -1)[:, 0]
    adv = jnp.ones(6)
    cfg = A2CConfig(total_steps=512, clip_eps=0.2, value_coef=0.0, entropy_coef=0.0)

    def grad_norm(old):
        g, _ = jax.grad(a2c_loss, has_aux=True)(params, net.apply, obs, None, actions, jnp.zeros(6), cfg, None,
                                                 old, adv)
        return float(optax.tree.norm(g))

    assert grad_norm(logp_a - 0.5) == 0.0  # ratio e^0.5 > 1.2: clipped
    assert grad_norm(logp_a) > 0.0  # ratio 1: inside
    # unclipped (A2C) with the same advantages has a gradient whatever old_log_probs
    g, _ = jax.grad(a2c_loss, has_aux=True)(params, net.apply, obs, None, actions, jnp.zeros(6),
                                            dataclasses.replace(cfg, clip_eps=None), None, logp_a - 0.5, adv)
    assert float(optax.tree.norm(g)) > 0.0


def test_ppo_options_run_and_keep_the_lr_schedule_per_update():
    cfg = A2CConfig(total_steps=4 * 4 * 8, num_envs=4, t_max=8, lr=1e-3, gae_lambda=0.9, clip_eps=0.2, epochs=2,
                    minibatches=4, normalize_advantages=True)
    assert cfg.steps_per_update == 8
    trainer = make_train(cfg, ENV, PARAMS, make_net("linear"))
    state = trainer.init(jax.random.PRNGKey(0))
    s1, m = trainer.update(state)
    assert np.isfinite(float(m["loss"])) and int(s1.update) == 1
    # 8 Adam steps in one update; the learning rate of update k is lr * (1 - k / num_updates)
    from jaxdc.agents.a2c import make_optimizer

    tx = make_optimizer(cfg)
    grads = jax.tree_util.tree_map(jnp.ones_like, state.params)
    opt = tx.init(state.params)
    sizes = []
    for _ in range(16):
        upd, opt = tx.update(grads, opt, state.params)
        sizes.append(float(optax.tree.norm(upd)))
    assert sizes[0] == pytest.approx(sizes[7], rel=1e-5) and sizes[8] < sizes[7] * 0.8
    # a different rollout use than A2C: the parameters differ from one plain A2C step
    plain = make_train(dataclasses.replace(cfg, gae_lambda=1.0, clip_eps=None, epochs=1, minibatches=1,
                                           normalize_advantages=False), ENV, PARAMS, make_net("linear"))
    s2, _ = plain.update(plain.init(jax.random.PRNGKey(0)))
    a, b = jax.tree_util.tree_leaves(s1.params)[0], jax.tree_util.tree_leaves(s2.params)[0]
    assert not np.allclose(np.asarray(a), np.asarray(b))


def test_huber_values():
    x = jnp.array([0.0, 0.5, -1.0, 2.0, -3.0])
    np.testing.assert_allclose(np.asarray(huber(x)), [0.0, 0.125, 0.5, 1.5, 2.5])


def test_lr_schedule_reaches_zero_at_t_max():
    cfg = A2CConfig(total_steps=10 * 512, lr=1e-4)
    sched = lr_schedule(cfg)
    assert cfg.num_updates == 10
    assert float(sched(0)) == pytest.approx(1e-4)
    assert float(sched(5)) == pytest.approx(5e-5)
    assert float(sched(10)) == 0.0 and float(sched(11)) == 0.0


@pytest.mark.parametrize("change, match", [
    ({"lr": 0.0}, "lr"), ({"lr": -1e-3}, "lr"), ({"total_steps": 0}, "total_steps"),
    ({"num_envs": 0}, "num_envs"), ({"total_steps": 100}, "total_steps"), ({"gamma": 1.5}, "gamma"),
    ({"entropy_coef": -0.1}, "entropy_coef"), ({"gae_lambda": 1.5}, "gae_lambda"), ({"clip_eps": 0.0}, "clip_eps"),
    ({"clip_eps": 1.0}, "clip_eps"), ({"epochs": 0}, "epochs"), ({"minibatches": 3}, "minibatches"),
])
def test_config_validation(change, match):
    with pytest.raises(ValueError, match=match):
        A2CConfig(**change)


def _leaves_equal(a, b):
    la, lb = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    assert len(la) == len(lb)
    for x, y in zip(la, lb):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


@pytest.fixture(scope="module")
def enn_trainer():
    """One ENN trainer (one compilation) shared by the resume and the learning test."""
    return make_train(A2CConfig(total_steps=8192, num_envs=16, t_max=8, lr=1e-3), ENV, PARAMS, make_net("enn"), HEUR)


def test_resume_through_a_checkpoint_is_exact(enn_trainer):
    trainer = enn_trainer
    state = trainer.init(jax.random.PRNGKey(3))
    straight = state
    for _ in range(20):
        straight, _ = trainer.update(straight)
    half = state
    for _ in range(10):
        half, _ = trainer.update(half)
    with tempfile.TemporaryDirectory() as d:
        checkpoint.save(d, 10, half, {"net": "enn"})
        resumed, meta = checkpoint.restore(d, trainer.init(jax.random.PRNGKey(99)), {"net": "enn"})
    assert meta["net"] == "enn" and int(resumed.update) == 10
    for _ in range(10):
        resumed, _ = trainer.update(resumed)
    _leaves_equal(resumed, straight)


def test_scan_layout_matches_the_loop_layout():
    trainer = make_train(A2CConfig(total_steps=3 * 32, num_envs=4, t_max=8), ENV, PARAMS, make_net("linear"))
    state = trainer.init(jax.random.PRNGKey(4))
    scanned, metrics = trainer.run(state, 3)
    looped = state
    for _ in range(3):
        looped, _ = trainer.update(looped)
    assert metrics["loss"].shape == (3,) and int(scanned.update) == 3
    for x, y in zip(jax.tree_util.tree_leaves(scanned), jax.tree_util.tree_leaves(looped)):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=1e-5, atol=1e-6)


def test_tiny_enn_run_beats_the_random_policy(enn_trainer):
    """ENN at initialisation is close to uniform; 8k steps lift the mean reward by > 1 (SE ~0.07)."""
    net, trainer = make_net("enn"), enn_trainer
    cfg = trainer.config
    evaluate = jax.jit(lambda params, key: run_episodes(ENV, PARAMS, make_policy(net, params, HEUR), key, 500))
    state = trainer.init(jax.random.PRNGKey(0))
    before = summarize(evaluate(state.params, jax.random.PRNGKey(7)))["reward"]["mean"]
    for _ in range(cfg.num_updates):
        state, metrics = trainer.update(state)
    assert np.isfinite(float(metrics["loss"]))
    after = summarize(evaluate(state.params, jax.random.PRNGKey(7)))["reward"]["mean"]
    assert after > before + 1.0, (before, after)
    # greedy evaluation is available and deterministic in the policy
    greedy = make_policy(net, state.params, HEUR, greedy=True)
    obs, s = ENV.reset(jax.random.PRNGKey(1), PARAMS)
    assert int(greedy(jax.random.PRNGKey(2), obs, s)) == int(greedy(jax.random.PRNGKey(3), obs, s))


def test_make_train_rejects_a_non_config():
    with pytest.raises(TypeError, match="A2CConfig"):
        make_train(dataclasses.asdict(A2CConfig()), ENV, PARAMS, make_net("linear"))


def test_a_heuristic_net_needs_heuristics():
    with pytest.raises(ValueError, match="heuristics"):
        make_train(A2CConfig(), ENV, PARAMS, make_net("enn"))


def test_aux_head_cross_entropy_and_wiring():
    """A network with an auxiliary head (EMNN, OMN + CoNN) adds ``aux_coef`` * Eq. 5.1 to the loss."""
    import flax.linen as nn

    from jaxdc.agents.a2c import a2c_loss, aux_cross_entropy

    logits = jnp.log(jnp.array([[0.5, 0.25, 0.25], [0.1, 0.1, 0.8]]))
    ce, acc = aux_cross_entropy(logits, jnp.array([0, 0]))
    np.testing.assert_allclose(float(ce), -(np.log(0.5) + np.log(0.1)) / 2, rtol=1e-6)
    assert float(acc) == 0.5

    class WithAux(nn.Module):  # declares the trainer contract (jaxdc.agents.common.Network)
        has_aux = True
        uses_heuristics = False
        aux_params = ()
        num_actions = 9

        @nn.compact
        def __call__(self, obs, heuristics):
            x = obs.reshape(obs.shape[0], -1)
            return nn.Dense(9)(x), nn.Dense(1)(x)[:, 0], nn.Dense(9, name="aux")(x)

        def value(self, obs):
            return self(obs, None)[1]

    net = WithAux()
    cfg = A2CConfig(total_steps=16 * 32, aux_coef=0.5)
    with pytest.raises(ValueError, match="aux_target"):
        make_train(cfg, ENV, PARAMS, net)
    obs = jnp.zeros((4, 4, 4, 2))
    params = net.init(jax.random.PRNGKey(0), obs, None)
    args = (params, net.apply, obs, None, jnp.zeros(4, jnp.int32), jnp.zeros(4))
    (with_aux, m), (without, _) = (a2c_loss(*args, cfg, jnp.zeros(4, jnp.int32)),
                                   a2c_loss(*args, dataclasses.replace(cfg, aux_coef=0.0), jnp.zeros(4, jnp.int32)))
    np.testing.assert_allclose(float(with_aux - without), 0.5 * float(m["aux_loss"]), rtol=1e-5)
    # the trainer feeds the labels from the step's info
    trainer = make_train(cfg, ENV, PARAMS, net, aux_target=lambda info: jnp.zeros_like(info["outcome"]))
    _, metrics = trainer.update(trainer.init(jax.random.PRNGKey(1)))
    assert "aux_accuracy" in metrics and np.isfinite(float(metrics["aux_loss"]))


def test_the_masked_loss_is_that_of_the_policy_over_the_allowed_actions():
    """``allowed`` (an action mask, beyond the thesis): all True changes nothing; otherwise the loss is that of
    the softmax over the allowed actions, finite, and the forbidden logits get no gradient."""
    config = a2c.A2CConfig(clip_eps=0.2, gae_lambda=0.95)
    rng = np.random.default_rng(1)
    params = {"logits": jnp.asarray(rng.normal(size=(4, 9)), jnp.float32), "v": jnp.asarray([0.1, 0.2, 0.3, 0.4])}

    def apply_fn(p, obs, h):
        return p["logits"], p["v"]

    actions, returns = jnp.asarray([0, 4, 8, 2]), jnp.asarray([1.0, 0.0, 2.0, -1.0])
    old, adv = jnp.log(jnp.full(4, 1 / 5)), jnp.asarray([0.5, -0.5, 1.0, 0.2])
    allowed = jnp.asarray(rng.random((4, 9)) < 0.5).at[jnp.arange(4), actions].set(True)

    def loss(p, mask):
        return a2c.a2c_loss(p, apply_fn, None, None, actions, returns, config, None, old, adv, None, mask)

    free, _ = loss(params, None)
    everything, _ = loss(params, jnp.ones((4, 9), bool))
    assert float(free) == float(everything)
    masked, metrics = loss(params, allowed)
    # the same loss from the allowed logits alone: the forbidden ones set to -inf by hand
    by_hand = {**params, "logits": jnp.where(allowed, params["logits"], -jnp.inf)}
    logp = jax.nn.log_softmax(by_hand["logits"])
    logp_a = logp[jnp.arange(4), actions]
    ratio = jnp.exp(logp_a - old)
    policy = -jnp.mean(jnp.minimum(ratio * adv, jnp.clip(ratio, 0.8, 1.2) * adv))
    entropy = -jnp.mean(jnp.sum(jnp.where(allowed, jnp.exp(logp) * logp, 0.0), axis=-1))
    assert float(metrics["policy_loss"]) == pytest.approx(float(policy), rel=1e-6)
    assert float(metrics["entropy"]) == pytest.approx(float(entropy), rel=1e-6)
    assert float(masked) != float(free)
    grads = jax.grad(lambda p: loss(p, allowed)[0])(params)["logits"]
    assert np.all(np.isfinite(np.asarray(grads)))
    np.testing.assert_array_equal(np.asarray(grads)[~np.asarray(allowed)], 0.0)


def test_a_bad_mask_is_refused_before_anything_is_compiled():
    from jaxdc.dcg.env import DCG
    from jaxdc.nets.registry import build

    env = DCG(grid_size=3, total_reward=3, strategies="restricted", history=1, obs_history=False)
    params, net = env.make_params(), build("dcg", "vnn", history=1, state_channels=env.state_channels)
    with pytest.raises(TypeError, match="mask must be a function state -> bool"):
        make_train(A2CConfig(), env, params, net, mask=3)
    with pytest.raises(ValueError, match=r"mask must return bool \[9\] for one state .* got bool \(4,\)"):
        make_train(A2CConfig(), env, params, net, mask=lambda s: jnp.ones(4, bool))
    with pytest.raises(ValueError, match=r"mask must return bool \[9\] .* got float32 \(9,\)"):
        make_train(A2CConfig(), env, params, net, mask=lambda s: jnp.ones(9))
