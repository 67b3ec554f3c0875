"""The package ``jaxdc`` itself: importing it (and every module) does no JAX computation."""

import subprocess
import sys

MODULES = ["jaxdc", "jaxdc.dcp.env", "jaxdc.dcg.env", "jaxdc.dcg.opponents", "jaxdc.wrappers.gymnasium",
           "jaxdc.core.paths", "jaxdc.viewer", "jaxdc.nets", "jaxdc.agents.a2c", "jaxdc.agents.nstep_q",
           "jaxdc.agents.parallel", "jaxdc.drp.tours", "jaxdc.dcp.evaluate", "jaxdc.dcg.evaluate", "jaxdc.pretrained"]


def test_import_starts_no_backend():
    # jax.distributed.initialize() must still be callable after `import jaxdc`: it refuses once a backend exists.
    code = ("import importlib, sys\n"
            f"for m in {MODULES!r}: importlib.import_module(m)\n"
            "from jax._src import xla_bridge as xb\n"
            "print('backends', len(xb._backends))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "backends 0" in out.stdout, out.stdout


# -- the registry and the gymnax-style interface ------------------------------------------


def test_registry_lists_what_make_accepts():
    import pytest

    import jaxdc

    assert jaxdc.registered_envs() == ("DCP-v0", "DCG-v0", "DCGTeam-v0")
    for env_id in jaxdc.registered_envs():
        env, params = jaxdc.make(env_id, energy=(5.0, 9.0) if env_id == "DCP-v0" else 9.0)
        assert env.name == env_id.split("-")[0] and env.observation_space(params).shape == env.observation_shape(params)
        env, params = jaxdc.make("jaxdc/" + env_id)  # the gymnasium spelling works too
    with pytest.raises(ValueError, match="unknown environment id 'DCX-v0'; available"):
        jaxdc.make("DCX-v0")


def test_make_builds_the_team_game_with_its_params():
    import jaxdc

    env, params = jaxdc.make("DCGTeam-v0", collectors=3, opponents=2, energy=9.0, energy_range=(5, 12),
                             max_steps=50)
    assert isinstance(env, jaxdc.DCGTeam) and (env.collectors, env.opponents) == (3, 2)
    assert float(params.max_energy) == 12.0 and int(params.max_steps) == 50
    assert env.observation_space(params).shape == (3, 5, 5, 13)
    assert env.action_space(params).shape == (3,)


class _FlattenObservation:
    """The shape of gymnax's ``FlattenObservationWrapper``: it reads the wrapped env's spaces."""

    def __init__(self, env):
        self._env = env

    def __getattr__(self, name):
        return getattr(self._env, name)

    def observation_space(self, params):
        from jaxdc.core import spaces
        box = self._env.observation_space(params)
        return spaces.Box(box.low.reshape(-1), box.high.reshape(-1), (box.low.size,))

    def reset(self, key, params=None):
        obs, state = self._env.reset(key, params)
        return obs.reshape(-1), state

    def step(self, key, state, action, params=None):
        obs, state, reward, term, trunc, info = self._env.step(key, state, action, params)
        return obs.reshape(-1), state, reward, term, trunc, info


def _make_train(env, params, num_envs=4, steps=16, updates=3, lr=0.05):
    """A PureJaxRL-style ``make_train(config) -> train(key)``: REINFORCE on a linear policy, all in jit."""
    import jax
    import jax.numpy as jnp

    obs_dim = env.observation_space(params).shape[0]
    n_act = env.action_space(params).n

    def train(key):
        w = jnp.zeros((obs_dim, n_act))
        key, k_reset = jax.random.split(key)
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k_reset, num_envs), params)

        def update(carry, key):
            w, obs, state = carry

            def step(c, k):
                obs, state = c
                k_a, k_s = jax.random.split(k)
                logits = obs @ w
                a = jax.random.categorical(k_a, logits)
                obs2, state2, r, term, trunc, _ = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                    jax.random.split(k_s, num_envs), state, a, params)
                return (obs2, state2), (obs, a, r)

            (obs, state), (o, a, r) = jax.lax.scan(step, (obs, state), jax.random.split(key, steps))
            ret = jnp.cumsum(r[::-1], axis=0)[::-1]

            def loss(w):
                logp = jax.nn.log_softmax(o @ w)
                return -jnp.mean(jnp.take_along_axis(logp, a[..., None], -1)[..., 0] * (ret - ret.mean()))

            w = w - lr * jax.grad(loss)(w)
            return (w, obs, state), r.sum()

        (w, _, _), rewards = jax.lax.scan(update, (w, obs, state), jax.random.split(key, updates))
        return w, rewards

    return train


def test_purejaxrl_style_jit_vmap_train_and_a_gymnax_style_wrapper():
    import jax
    import numpy as np

    import jaxdc

    for env_id, kw in (("DCP-v0", dict(grid_size=4, total_reward=5, max_steps=20)),
                       ("DCG-v0", dict(grid_size=4, total_reward=3, max_steps=20))):
        env, params = jaxdc.make(env_id, **kw)
        flat = _FlattenObservation(env)
        assert flat.observation_space(params).shape == (int(np.prod(env.observation_shape(params))),)
        w, rewards = jax.jit(jax.vmap(_make_train(flat, params)))(jax.random.split(jax.random.PRNGKey(0), 3))
        assert w.shape == (3, flat.observation_space(params).shape[0], 9) and rewards.shape == (3, 3)
        assert np.all(np.isfinite(np.asarray(w))) and np.all(np.asarray(rewards) >= 0)
        assert not np.allclose(np.asarray(w[0]), np.asarray(w[1]))  # different seeds, different runs
