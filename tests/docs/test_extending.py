"""docs/extending.md's worked example runs: a new environment, generator, network, preset, yardstick and claim
(docs/examples/extending_example.py), and the guide's code blocks are the example's own lines."""

from __future__ import annotations

import importlib.util
import re
import sys
import textwrap
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import generators
from jaxdc.core.claims import AGREES, Verdict
from jaxdc.core.env import step_batch
from jaxdc.core.scene import Scene
from jaxdc.dcp.env import DCP
from jaxdc.dcp.instances import instance_params
from jaxdc.nets import registry
from jaxdc.training import presets

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "extending.md"
EXAMPLE = ROOT / "docs" / "examples" / "extending_example.py"


def _load():
    spec = importlib.util.spec_from_file_location("extending_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve their module by name
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


ex = _load()


@pytest.fixture
def registered(monkeypatch):
    """The example registered in copies of the library's registries: nothing leaks into other tests."""
    monkeypatch.setattr(registry, "REGISTRIES", dict(registry.REGISTRIES))
    monkeypatch.setattr(presets, "EVERY", dict(presets.EVERY))
    ex.register()
    return ex


def test_the_guide_shows_the_example_s_own_code():
    """Every ```python block of docs/extending.md is a passage of the example module, so the guide cannot drift."""
    source = EXAMPLE.read_text()
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
    assert len(blocks) >= 6
    for block in blocks:
        lines = [line for line in textwrap.dedent(block).splitlines() if line.strip() != "..."]
        for line in lines:
            assert line.strip() == "" or line.rstrip() in source, f"not in the example: {line!r}"


def test_the_environment_steps_under_jit_and_vmap():
    env = ex.Pickup(grid_size=3)
    params = env.make_params("high", max_steps=6)
    assert env == ex.Pickup(3) and hash(env) == hash(ex.Pickup(3)) and env != ex.Pickup(4)
    assert env.observation_space(params).shape == (3, 3, 2) and env.action_space(params).n == 9
    b = 64
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(jax.random.split(jax.random.PRNGKey(0), b), params)
    assert obs.shape == (b, 3, 3, 2) and bool(jnp.all(obs.sum((1, 2)) == 1))  # one item, one agent
    assert not bool(jnp.any(state.items[:, 0, 0]))  # never on the base
    step = jax.jit(lambda k, s, a: step_batch(env, k, s, a, params))
    key = jax.random.PRNGKey(1)
    ended = 0
    for _ in range(8):
        key, k_act, k_step = jax.random.split(key, 3)
        obs, state, reward, term, trunc, info = step(k_step, state, jax.random.randint(k_act, (b,), 0, 9))
        assert obs.shape == (b, 3, 3, 2) and reward.shape == (b,)
        assert bool(jnp.all(~(term & trunc))) and bool(jnp.all(reward <= 1))
        ended += int(jnp.sum(term | trunc))
    assert ended >= b  # every episode ends within max_steps = 6 steps and is reset
    assert bool(env.observation_space(params).contains(obs[0]))
    one = jax.tree_util.tree_map(lambda x: x[0], state)
    text = env.render_ansi(one, params)
    assert text.count("\n") == 4 and "A" in text and "reward" in text
    assert isinstance(env.scene(one, params), Scene) and env.outcomes[int(one.outcome)] in ex.OUTCOMES


def test_the_generator_draws_maps_that_the_dcp_plays():
    gen = ex.Stripes(0.2, 0.4)
    assert gen == ex.Stripes(0.2, 0.4) and gen.describe() == {"kind": "stripes", "low": 0.2, "high": 0.4}
    with pytest.raises(ValueError):
        ex.Stripes(0.5, 0.2)
    maps = generators.make_maps(gen, generators.SeedSet(0, 4), 3)
    assert maps.shape == (4, 3, 3) and np.all(maps[:, 0] == 0) and np.all(maps[:, 2] == 0)
    assert np.all((maps[:, 1] >= 0.2) & (maps[:, 1] <= 0.4)) and len(set(maps[:, 1, 0].tolist())) == 4
    np.testing.assert_array_equal(maps, generators.make_maps(gen, generators.SeedSet(0, 4), 3))  # seeded
    dcp = DCP(grid_size=3, total_reward=2)
    params = instance_params(dcp, maps, (4, 6))
    assert params.maps.shape == (4, 3, 3)
    play = jax.jit(lambda key: dcp.step(key, dcp.reset(key, params)[1], 4, params))  # reset, one step
    obs, state, *_ = play(jax.random.PRNGKey(0))
    assert obs.shape == (3, 3, 2) and 0 <= int(state.map_id) < 4 and 4 <= float(state.max_energy) <= 6
    env = ex.Pickup(3)  # and the new environment takes one of them as its map
    np.testing.assert_array_equal(np.asarray(env.make_params(maps[0]).risk), maps[0])


def test_the_network_is_built_by_name(registered):
    assert registry.names("pickup") == ("mlp",) and registry.entry("pickup", "mlp").algorithm == registry.A2C
    net = registry.build("pickup", "mlp")
    obs = jnp.zeros((5, 3, 3, 2))
    logits, value = net.apply(net.init(jax.random.PRNGKey(0), obs), obs)
    assert logits.shape == (5, 9) and value.shape == (5,)


def test_the_named_configuration_renders_its_flags(registered):
    assert presets.names("pickup") == ["pickup_mlp"]
    preset = presets.EVERY["pickup_mlp"]
    assert preset.flags() == ["--net", "mlp", "--steps", "50000", "--envs", "16", "--lr", "1e-3"]
    assert "pickup_mlp" in presets.listing("pickup")


def test_registering_does_not_leak():
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(registry, "REGISTRIES", dict(registry.REGISTRIES))
        mp.setattr(presets, "EVERY", dict(presets.EVERY))
        ex.register()
        assert "pickup" in registry.REGISTRIES
    assert "pickup" not in registry.REGISTRIES and "pickup_mlp" not in presets.EVERY


def test_the_yardstick_is_exact_on_hand_cases():
    free = np.zeros((3, 3))
    assert ex.optimal_value(free, 2) == 1.0  # every cell of a 3x3 grid is within 2 moves of the base
    assert ex.optimal_value(free, 1) == pytest.approx(3 / 8)  # one step reaches the 3 neighbours of 8 cells
    risky = np.full((3, 3), 0.5)
    risky[0, 0] = 0
    assert ex.optimal_value(risky, 2) == pytest.approx((3 + 5 * 0.5) / 8)  # one risky cell on the way
    assert ex.optimal_value(risky, 6) >= ex.optimal_value(risky, 2)


def test_a_random_policy_does_not_beat_the_yardstick_and_the_claims_are_judged():
    env = ex.Pickup(3)
    params = env.make_params("high", max_steps=4)
    optimum = ex.optimal_value(params.risk, 4)
    mean, se = ex.mean_reward(env, params, ex.random_policy, jax.random.PRNGKey(0), 2000)
    assert 0 < mean <= optimum + 2 * se
    verdicts = ex.judge_claims(ex.Measured(optimum, mean, se))
    assert all(isinstance(v, Verdict) and v.agrees in AGREES for v in verdicts)
    assert [v.agrees for v in verdicts] == ["yes", "yes"]
    assert [v.agrees for v in ex.judge_claims(ex.Measured(0.5, 0.9, 0.01))] == ["no", "no"]


def test_generic_code_reads_the_hooks():
    """The gymnasium adapter and the viewer take the new environment without knowing it (section 1's hooks)."""
    from jaxdc.viewer import render_frame
    from jaxdc.wrappers.gymnasium import JaxToGymnasium

    env = ex.Pickup(3)
    params = env.make_params("low", max_steps=3)
    gym = JaxToGymnasium(env, params, render_mode="ansi")
    obs, _ = gym.reset(seed=0)
    assert obs.shape == (3, 3, 2) and gym.observation_space.contains(obs)
    done = False
    while not done:
        obs, reward, terminated, truncated, info = gym.step(8)
        done = terminated or truncated
    assert info["outcome"] in ex.OUTCOMES[1:] and "reward" in gym.render()
    _, state = env.reset(jax.random.PRNGKey(0), params)
    frame = render_frame(env, params, state)
    assert frame.dtype == np.uint8 and frame.ndim == 3
