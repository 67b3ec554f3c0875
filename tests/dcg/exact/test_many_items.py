"""The full-information optimum of many-item DCG games (jaxdc.dcg.exact.many_items): brute force over every action
sequence in the env, agreement with the single-item solver, the optimal plans replayed in the env, and
collectors that never beat it."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.cli import eval_dcg as cli
from jaxdc.core import grid
from jaxdc.dcg import DCG
from jaxdc.dcg.exact import many_items as go
from jaxdc.dcg.exact import one_item
from tests.support.dcg_games import best_sequence, play_sequence, resets, simulate


def optima(env, params, states):
    machines = go.opponent_machines(env, params)
    count = states.time.shape[0]
    return [go.game_optimum(env, machines, jax.tree_util.tree_map(lambda x, i=i: x[i], states)) for i in range(count)]


def replay(env, params, states, plans):
    """Total reward of each game when its plan is played in the env (padded with 'stay')."""
    length = max(1, max(p.size for p in plans))
    seqs = np.zeros((len(plans), length), np.int32)
    for i, p in enumerate(plans):
        seqs[i, : p.size] = p

    play = jax.vmap(lambda state, seq: play_sequence(env, params, state, seq))
    return np.asarray(jax.jit(play)(states, jnp.asarray(seqs)))


@pytest.mark.parametrize("counts,tie", [(True, "straight"), (False, "order")])
def test_matches_brute_force_over_all_action_sequences(counts, tie):
    env = DCG(grid_size=3, total_reward=4, history=1, obs_history=False, reward_when_caught=counts)
    params = env.make_params(energy=3.0, max_steps=5, chase_tie=tie)
    states = resets(env, params, 48, seed=1)
    want = best_sequence(env, params, states, 5)
    got = np.array([g.reward for g in optima(env, params, states)])
    assert len(set(want.tolist())) >= 3, "a degenerate case tests nothing"
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("rules", [dict(capture="opponent_moves"), dict(safe_base=True),
                                   dict(opponent_enters_base=False), dict(capture="opponent_moves", safe_base=True)],
                         ids=["opponent_moves", "safe_base", "opponent_out_of_base", "both_readings"])
def test_rule_readings_match_brute_force(rules):
    """The env's rule readings (docs/dcg.md, "Rule readings") and the search agree: brute force in the env."""
    env = DCG(grid_size=3, total_reward=4, history=1, obs_history=False, **rules)
    params = env.make_params(energy=3.0, max_steps=5)
    states = resets(env, params, 48, seed=1)
    want = best_sequence(env, params, states, 5)
    got = np.array([g.reward for g in optima(env, params, states)])
    assert len(set(want.tolist())) >= 3, "a degenerate case tests nothing"
    np.testing.assert_array_equal(got, want)
    plain = DCG(grid_size=3, total_reward=4, history=1, obs_history=False)
    assert not np.array_equal(want, best_sequence(plain, params, resets(plain, params, 48, seed=1), 5)), \
        "the reading changes nothing here"


def test_one_item_agrees_with_the_single_item_solver():
    env = DCG(grid_size=4, reward_area=3, history=1, obs_history=False)
    params = env.make_params(energy=6.0, max_steps=30)
    sol = one_item.solve(env, params)
    states = resets(env, params, 200, seed=2)
    n = env.grid_size
    flat = lambda xy: np.asarray(xy)[:, 0] * n + np.asarray(xy)[:, 1]  # noqa: E731
    item = np.asarray(states.items).reshape(200, -1).argmax(-1)
    want = sol.values[np.asarray(states.strategy), flat(states.opponent.home), flat(states.opponent.target), item]
    got = np.array([g.reward for g in optima(env, params, states)])
    assert 0 < want.mean() < 1
    np.testing.assert_array_equal(got, want)


@pytest.fixture(scope="module")
def many_items():
    """Six units on a 4 x 4 grid, energy 6, step cap 40: the standard game scaled down."""
    env = DCG(grid_size=4, total_reward=6, history=1, obs_history=False)
    params = env.make_params(energy=6.0, max_steps=40)
    states = resets(env, params, 120, seed=3)
    return env, params, states, optima(env, params, states)


def test_plans_earn_exactly_the_optimum_in_the_env(many_items):
    env, params, states, out = many_items
    got = replay(env, params, states, [g.plan for g in out])
    want = np.array([g.reward for g in out])
    np.testing.assert_array_equal(got, want)
    assert 0 < want.mean() < env.total_reward and want.max() == env.total_reward


def test_no_collector_beats_the_optimum_in_any_game(many_items):
    env, params, states, out = many_items
    want = np.array([g.reward for g in out])

    def nearest_item(key, obs, state):
        n = state.items.shape[0]
        cells = jnp.stack(jnp.divmod(jnp.arange(n * n), n), -1)
        d = jnp.where(state.items.reshape(-1) > 0, grid.chebyshev(cells, state.pos), 1 << 20)
        step = grid.shortest_move(state.pos, cells[jnp.argmin(d)], n)
        k_coin, k_action = jax.random.split(key)
        rand = jax.random.randint(k_action, (), 0, grid.NUM_ACTIONS)
        return jnp.where(jax.random.bernoulli(k_coin, 0.3), rand, step)

    for seed in range(3):
        got = simulate(env, params, nearest_item, states, 40, seed=seed)
        assert np.all(got <= want), "a collector beat the full-information optimum in some game"
        assert 0 < got.mean() < want.mean()


def test_sampled_bound_statistics():
    env = DCG(grid_size=4, total_reward=5, history=1, obs_history=False)
    params = env.make_params(energy=6.0, max_steps=40)
    res = go.sampled_bound(env, params, jax.random.PRNGKey(0), 60)
    r = res["rewards"]
    assert r.shape == (60,) and res["mean"] == pytest.approx(r.mean())
    assert res["se"] == pytest.approx(r.std(ddof=1) / np.sqrt(60))
    assert sum(v["episodes"] for v in res["per_strategy"].values()) == 60
    assert res["per_strategy"]["patrol"]["mean"] >= res["per_strategy"]["restricted"]["mean"]
    again = go.sampled_bound(env, params, jax.random.PRNGKey(0), 60)["rewards"]
    np.testing.assert_array_equal(r, again)
    # more energy never lowers any game's optimum
    more = go.sampled_bound(env, env.make_params(energy=float("inf"), max_steps=40), jax.random.PRNGKey(0), 60)
    assert np.all(more["rewards"] >= r) and more["mean"] > res["mean"]


def test_bad_input():
    env = DCG(grid_size=3, total_reward=3, history=1, obs_history=False)
    params = env.make_params(energy=4.0)
    machines = go.opponent_machines(env, params)
    _, state = env.reset_env(jax.random.PRNGKey(0), params)
    with pytest.raises(ValueError, match="reset state"):
        go.game_optimum(env, machines, state.replace(time=jnp.int32(3)))
    with pytest.raises(ValueError, match="max_energy"):
        go.game_optimum(env, machines, state.replace(energy=jnp.float32(2.0)))
    with pytest.raises(ValueError, match="item cells"):
        big = DCG(grid_size=5, history=1, obs_history=False)
        bp = big.make_params()
        _, s = big.reset_env(jax.random.PRNGKey(0), bp)
        go.game_optimum(big, go.opponent_machines(big, bp), s.replace(items=jnp.ones((5, 5))))
    with pytest.raises(ValueError, match="chase_tie"):
        go.opponent_machines(env, env.make_params(chase_tie="random"))
    with pytest.raises(ValueError, match="grid_size"):
        go.opponent_machines(DCG(grid_size=8, history=1), DCG(grid_size=8, history=1).make_params())
    with pytest.raises(ValueError, match="episodes"):
        go.sampled_bound(env, params, jax.random.PRNGKey(0), 0)


def test_cli(tmp_path, capsys):
    argv = ["optimum", "--grid-size", "3", "--total-reward", "3", "--energy", "4", "--episodes", "12",
            "--no-progress", "--json", "--out", str(tmp_path)]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["optimum"]["episodes"] == 12 and 0 <= out["optimum"]["mean"] <= 3
    assert sum(out["reward_histogram"].values()) == 12
    assert out["command"].startswith("python -m eval.dcg optimum --grid-size 3")
    written = list(tmp_path.glob("optimum_*.json"))
    assert len(written) == 1 and json.loads(written[0].read_text())["optimum"] == out["optimum"]
    with pytest.raises(SystemExit) as e:
        cli.main(["optimum", "--energy", "2.5", "--episodes", "2", "--out", str(tmp_path)])
    assert e.value.code == 2 and "--energy must be a whole number" in capsys.readouterr().err
