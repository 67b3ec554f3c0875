"""The exact full-information bound of the single-item DCG (jaxdc.dcg.exact.one_item): hand-computed games,
brute force over every action sequence in the real env, the optimal plans replayed in the env, and
heuristics that never beat it."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.dcg import DCG
from jaxdc.dcg.exact import one_item
from tests.support.dcg_games import best_sequence, resets, simulate


def predicted(sol, states):
    """The solver's 0/1 value of each reset state (strategy, opponent start and far end, item cell)."""
    n = sol.grid_size
    flat = lambda xy: np.asarray(xy)[:, 0] * n + np.asarray(xy)[:, 1]  # noqa: E731
    item = np.asarray(states.items).reshape(states.items.shape[0], -1).argmax(-1)
    return sol.values[np.asarray(states.strategy), flat(states.opponent.home), flat(states.opponent.target), item]


def straight_to_item(key, obs, state):
    n = state.items.shape[0]
    item = jnp.argmax(state.items.reshape(-1))
    return grid.shortest_move(state.pos, jnp.stack([item // n, item % n]), n)


def half_random(key, obs, state):
    """Straight to the item or, with probability 1/2, a uniformly random action."""
    k_coin, k_action = jax.random.split(key)
    rand = jax.random.randint(k_action, (), 0, grid.NUM_ACTIONS)
    return jnp.where(jax.random.bernoulli(k_coin), rand, straight_to_item(key, obs, state))


# -- hand-computed games on a 2 x 2 grid ----------------------------------------------------------


@pytest.mark.parametrize("counts,expected", [(True, (1.0, 1 / 3, 1.0)), (False, (1.0, 1 / 3, 2 / 3))])
def test_two_by_two_by_hand(counts, expected):
    # The item is on (1,1); the opponent starts on (0,1), (1,0) or (1,1).
    # restricted: from (0,1) or (1,0) it steps onto the collector in the base first (0); from (1,1) it steps
    #   up to (0,1) (rows first on a tie) and the collector walks diagonally onto the item (1): 1/3.
    # with_fog: stays while the collector is in the fog, which is every cell but (1,1): from (0,1)/(1,0) the
    #   collector walks onto the item; on (1,1) it can only take the item by walking into the opponent,
    #   which counts iff reward_when_caught: 1 or 2/3.
    # patrol: always 1 (it leaves the item's cell, or the collector waits for it to).
    env = DCG(grid_size=2, reward_area=1, history=1, reward_when_caught=counts)
    out = one_item.full_information_bound(env, env.make_params(energy=15.0))
    assert out["per_strategy"] == pytest.approx(dict(zip(env.strategies, expected)))
    assert out["total"] == pytest.approx(np.mean(expected)) and out["reward_area"] == 1


def test_energy_and_step_cap_bind():
    # The item on (2,2) of a 3 x 3 grid needs two moves: impossible with energy 1 or a step cap of 1.
    env = DCG(grid_size=3, reward_area=1, history=1)
    assert one_item.full_information_bound(env, env.make_params(energy=1.0))["total"] == 0.0
    assert one_item.full_information_bound(env, env.make_params(energy=15.0, max_steps=1))["total"] == 0.0
    two = one_item.full_information_bound(env, env.make_params(energy=2.0))
    assert two["per_strategy"]["patrol"] > 0.0
    assert one_item.full_information_bound(env, env.make_params(energy=float("inf")))["total"] >= two["total"]


# -- brute force: every action sequence in the real env ---------------------------------------------


def all_reset_states(env, params):
    """Every reset state of a one-item game (strategy x opponent start/end x item cell) and its weight."""
    sol_weight = one_item.reset_pairs(env)
    _, template = env.reset_env(jax.random.PRNGKey(0), params)
    n = env.grid_size
    rows = [(s, h, t, i) for s in range(len(env.strategies)) for h, t in zip(*np.nonzero(sol_weight > 0))
            for i in env.reward_area_cells()]
    s, h, t, i = (np.array(x) for x in zip(*rows))
    xy = lambda f: jnp.asarray(np.stack(np.divmod(f, n), -1), jnp.int32)  # noqa: E731
    items = np.zeros((len(rows), n * n), np.float32)
    items[np.arange(len(rows)), i] = 1.0
    batch = jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (len(rows),) + x.shape), template)
    opp = batch.opponent.replace(pos=xy(h), home=xy(h), target=xy(t))
    return batch.replace(strategy=jnp.asarray(s, jnp.int32), items=jnp.asarray(items.reshape(-1, n, n)), opponent=opp)


@pytest.mark.parametrize(
    "area,horizon,energy,counts,tie", [(2, 2, 2.0, True, "straight"), (1, 3, 15.0, False, "order")])
def test_matches_brute_force_over_all_action_sequences(area, horizon, energy, counts, tie):
    env = DCG(grid_size=3, reward_area=area, history=1, obs_history=False, reward_when_caught=counts)
    params = env.make_params(energy=energy, max_steps=horizon, chase_tie=tie)
    sol = one_item.solve(env, params)
    states = all_reset_states(env, params)
    want = predicted(sol, states)
    assert 0 < want.mean() < 1, "a degenerate case tests nothing"
    np.testing.assert_array_equal(best_sequence(env, params, states, horizon), want)


# -- the plans replayed in the env; heuristics never beat the bound -----------------------------------


@pytest.fixture(scope="module")
def thesis_game():
    """The game of section 5.5.5 on a 4 x 4 grid (5 x 5 in docs/dcg.md), energy 6, reward area 2, step cap 30."""
    env = DCG(grid_size=4, reward_area=2, history=1, obs_history=False)
    params = env.make_params(energy=6.0, max_steps=30)
    return env, params, one_item.solve(env, params)


def test_optimal_plans_collect_exactly_what_the_solver_says(thesis_game):
    env, params, sol = thesis_game
    states = resets(env, params, 600, seed=3)
    got = simulate(env, params, one_item.optimal_policy(sol), states, sol.plans.shape[-1])
    want = predicted(sol, states)
    np.testing.assert_array_equal(got, want)
    bound = one_item.full_information_bound(env, params, solution=sol)["total"]
    assert abs(got.mean() - bound) < 4 * np.sqrt(bound * (1 - bound) / got.size)
    assert 0.5 < bound < 1.0


def test_no_heuristic_beats_the_bound_in_any_game(thesis_game):
    env, params, sol = thesis_game
    states = resets(env, params, 800, seed=4)
    got = simulate(env, params, half_random, states, 30, seed=5)
    want = predicted(sol, states)
    assert np.all(got <= want), "a collector beat the full-information optimum in some game"
    assert 0.0 < got.mean() < want.mean()


def test_bound_per_reward_area_reuses_the_solution(thesis_game):
    env, params, sol = thesis_game
    n = env.grid_size
    whole = one_item.full_information_bound(DCG(grid_size=n, history=1), params, solution=sol)["total"]
    assert one_item.full_information_bound(env, params, n, solution=sol)["total"] == pytest.approx(whole)
    # the bound of the square of side s is the item-count-weighted mix of the ring (L-shaped) areas
    totals = [one_item.full_information_bound(env, params, s, solution=sol)["total"] for s in range(1, n + 1)]
    assert 0.0 < min(totals) and max(totals) < 1.0
    others = one_item.bound_from_solution(sol, [n * n - 2, n * n - n - 2, n * n - n - 1])["total"]
    assert totals[1] * 4 == pytest.approx(totals[0] + 3 * others)
    with pytest.raises(ValueError, match="solution"):
        one_item.full_information_bound(env, env.make_params(energy=7.0, max_steps=30), solution=sol)
    one = one_item.full_information_bound(env, params, 1, solution=sol)
    assert set(one["per_strategy"]) == set(env.strategies) and one["reward_area"] == 1
    assert one["total"] == pytest.approx(np.mean(list(one["per_strategy"].values())))


# -- bad input ---------------------------------------------------------------------------------------


def test_bad_input():
    env = DCG(grid_size=3, reward_area=1, history=1)
    with pytest.raises(ValueError, match="chase_tie"):
        one_item.solve(env, env.make_params(chase_tie="random"))
    with pytest.raises(ValueError, match="max_energy"):
        one_item.solve(env, env.make_params(energy=2.5))
    with pytest.raises(ValueError, match="reward_area"):
        one_item.full_information_bound(env, env.make_params(), reward_area=4)
    with pytest.raises(ValueError, match="grid_size"):
        one_item.solve(DCG(grid_size=8, history=1), DCG(grid_size=8, history=1).make_params())
    batch = jax.vmap(lambda e: env.make_params().replace(max_energy=e))(jnp.array([3.0, 4.0]))
    with pytest.raises(ValueError, match="scalar"):
        one_item.solve(env, batch)
