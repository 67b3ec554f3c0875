"""jaxdc.core.memory: requests too big for the machine are refused before anything is allocated."""

import jax
import pytest

from jaxdc.core import grid, memory, paths
from jaxdc.core.rollout import run_episodes
from jaxdc.dcp.env import DCP


def test_limit_from_the_environment(monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", "1e6")
    assert memory.available_bytes() == 1_000_000
    with pytest.raises(MemoryError, match=r"needs about .* but 977 KiB is available; lower the grid size"):
        paths.safest_paths(grid.risk_map("high", 12))  # 128 * 12**4 = 2.7 MB
    memory.check_fits(999_999, "x", "y")


def test_too_many_episodes_are_refused_before_the_rollout(monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(10 * 2**20))
    env = DCP(grid_size=4, total_reward=3)
    params = env.make_params(risk="low", energy=(4.0, 8.0), max_steps=10)

    def policy(k, obs, state):
        return jax.random.randint(k, (), 0, 9)

    with pytest.raises(MemoryError, match="1000000 evaluation episodes .* lower the number of episodes"):
        run_episodes(env, params, policy, jax.random.PRNGKey(0), 1_000_000)
    assert run_episodes(env, params, policy, jax.random.PRNGKey(0), 20).time.shape == (20,)


def test_tree_bytes():
    assert memory.tree_bytes({"a": jax.ShapeDtypeStruct((3, 4), "float32"), "b": jax.numpy.zeros(2, "int8")}) == 50


def test_total_reward_and_stored_episodes_are_bounded(monkeypatch):
    from jaxdc.core.trajectory import play_episode
    from jaxdc.dcg.env import DCG

    for make in (lambda: DCP(total_reward=2**24 + 1), lambda: DCG(total_reward=2_000_000_000)):
        with pytest.raises(ValueError, match=r"total_reward must be in \[1, 16777216\]"):
            make()
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(2**20))
    env = DCP(grid_size=4, total_reward=3)
    params = env.make_params(risk="low", energy=(4.0, 8.0), max_steps=10)
    with pytest.raises(MemoryError, match="lower max_steps"):
        play_episode(env, params, lambda k, o, s: 0, jax.random.PRNGKey(0), 100_000)


@pytest.mark.parametrize("value", ["abc", "-5", "0", "0.5", "nan", "inf", "-inf", "1e999"])
def test_a_bad_limit_is_refused_naming_the_variable(monkeypatch, value):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", value)
    with pytest.raises(ValueError, match=rf"JAXDC_MEMORY_LIMIT='{value}' must be a number of bytes >= 1"):
        memory.available_bytes()
    with pytest.raises(ValueError, match="JAXDC_MEMORY_LIMIT"):
        memory.check_fits(10, "x", "y")


def test_small_sizes_print_readably(monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", "1000")
    with pytest.raises(MemoryError, match=r"needs about 2 KiB but 1000 bytes is available"):
        memory.check_fits(2000, "x", "y")
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", "1e5")
    with pytest.raises(MemoryError, match=r"needs about 195 KiB but 98 KiB is available"):
        memory.check_fits(200_000, "x", "y")
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", " 1e6 ")
    assert memory.available_bytes() == 1_000_000
