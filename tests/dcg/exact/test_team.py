"""The two-collector full-information optimum (jaxdc.dcg.exact.team): equal to a brute force over every joint action
sequence by an independent plain-Python implementation of the team rules (docs/dcg.md, "The team game"), for every
standard strategy and both fog readings; its plans earn it; never below the one-collector optimum."""

import functools
import itertools

import jax
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.dcg import DCG
from jaxdc.dcg.exact import many_items, team
from jaxdc.dcg.opponents import CHASE_TIES

STRATEGIES = ("patrol", "restricted", "with_fog", "double_blind")


# -- the team rules in plain Python (independent of the search's tables) -----------------------------------------
def _clip(n, cell, a):
    dr, dc = (int(x) for x in grid.DELTAS_NP[a])
    return min(max(cell[0] + dr, 0), n - 1), min(max(cell[1] + dc, 0), n - 1)


def _chase(n, pos, goal, diagonal, tie):
    """'moves towards': the fewest moves left (Chebyshev with 9 actions, Manhattan with the first 5), then the
    straightest (tie 'straight'), then the first action."""
    acts = range(9 if diagonal else 5)

    def left(a):
        r, c = _clip(n, pos, a)
        dr, dc = abs(r - goal[0]), abs(c - goal[1])
        return max(dr, dc) if diagonal else dr + dc

    best = min(left(a) for a in acts)
    cand = [a for a in acts if left(a) == best]
    if tie == "straight":
        e2 = {a: sum((x - y) ** 2 for x, y in zip(_clip(n, pos, a), goal)) for a in cand}
        cand = [a for a in cand if e2[a] == min(e2.values())]
    return cand[0]


def _fog(cell):
    return cell[0] == 0 or cell[1] == 0


def _opponent(n, name, tie, fog_target, opp, cells, active):
    """The opponent's new (pos, phase): its target is the nearest active collector (ties: lowest index)."""
    pos, phase, home, far = opp
    if name == "patrol":
        goal = far if phase == 0 else home
        if pos == goal:
            phase = 1 - phase
        return _clip(n, pos, _chase(n, pos, far if phase == 0 else home, True, tie)), phase
    manhattan = name == "restricted"

    def dist(cell):
        dr, dc = abs(cell[0] - pos[0]), abs(cell[1] - pos[1])
        return dr + dc if manhattan else max(dr, dc)

    alive = [i for i in range(len(cells)) if active[i]]
    fog_rule = name in ("with_fog", "double_blind")
    if fog_rule and fog_target == "visible":
        alive = [i for i in alive if not _fog(cells[i])]
        if not alive:
            return pos, phase
    target = cells[min(alive, key=lambda i: (dist(cells[i]), i))]
    if fog_rule and _fog(target):
        return pos, phase
    return _clip(n, pos, _chase(n, pos, target, not manhattan, tie)), phase


def brute_force(env, params, state, fog_target):
    """The best team reward over every joint action sequence, by recursion over the game tree (memoised on the
    whole state and the time, which is exhaustive: equal states have equal futures)."""
    n, name = env.grid_size, env.strategies[int(state.strategy)]
    tie = CHASE_TIES[int(params.chase_tie)]
    energy, cap = float(params.max_energy), int(params.max_steps)
    home, far = tuple(int(x) for x in state.opponent.home), tuple(int(x) for x in state.opponent.target)
    items0 = tuple(float(x) for x in np.asarray(state.items).reshape(-1))

    def transition(s, acts):
        items, cells, energies, active, opp_pos, phase = s
        q, phase = _opponent(n, name, tie, fog_target, (opp_pos, phase, home, far), cells, active)
        items, cells, energies, active, reward = list(items), list(cells), list(energies), list(active), 0.0
        for i in range(2):
            if not active[i]:
                continue
            if cells[i] == q and not (env.safe_base and cells[i] == (0, 0)):  # rule (1)
                active[i] = False
                continue
            cells[i] = _clip(n, cells[i], acts[i])  # rule (2)
            met = (env.capture == "both" and cells[i] == q and not (env.safe_base and cells[i] == (0, 0)))
            k = cells[i][0] * n + cells[i][1]
            if items[k] > 0 and (env.reward_when_caught or not met):
                reward, items[k] = reward + items[k], 0.0
            if met:  # rule (3)
                active[i] = False
                continue
            energies[i] = energy if cells[i] == (0, 0) else energies[i] - 1  # rule (4)
            if energies[i] <= 0:
                active[i] = False
        over = not any(active) or not any(x > 0 for x in items)
        return (tuple(items), tuple(cells), tuple(energies), tuple(active), q, phase), reward, over

    @functools.lru_cache(maxsize=None)
    def value(s, t):
        if t == cap:
            return 0.0
        # every action of an active collector, one per distinct cell it leads to (the rest repeat it)
        choices = [list({_clip(n, s[1][i], a): a for a in range(8, -1, -1)}.values()) if s[3][i] else (0,)
                   for i in range(2)]
        best = 0.0
        for acts in itertools.product(*choices):
            nxt, r, over = transition(s, acts)
            best = max(best, r + (0.0 if over else value(nxt, t + 1)))
        return best

    start = (items0, ((0, 0), (0, 0)), (energy, energy), (True, True), tuple(int(x) for x in state.opponent.pos), 0)

    def play(plan):
        s, total = start, 0.0
        for acts in plan:
            s, r, over = transition(s, tuple(int(a) for a in acts))
            total += r
            if over:
                break
        return total

    return value(start, 0), play


def _games(env, params, count, seed):
    return list(many_items.games(many_items.draw_games(env, params, jax.random.PRNGKey(seed), count), count))


# -- the search against the brute force -----------------------------------------------------------------------------
@pytest.mark.parametrize("strategy", STRATEGIES)
@pytest.mark.parametrize("size,units,energy,steps", [(2, 3, 1.0, 4), (3, 4, 2.0, 3)], ids=["2x2", "3x3"])
def test_matches_brute_force(strategy, size, units, energy, steps):
    """Every standard strategy (and double_blind), both fog readings, on 2 x 2 and 3 x 3 games."""
    env = DCG(grid_size=size, total_reward=units, strategies=(strategy,), history=1, obs_history=False)
    params = env.make_params(energy=energy, max_steps=steps, chase_tie="straight" if size == 3 else "order")
    machines = many_items.opponent_machines(env, params)
    got, want = [], []
    for state in _games(env, params, 12, seed=size):
        for fog_target in team.FOG_TARGETS:
            opt = team.game_optimum(env, machines, state, fog_target)
            best, play = brute_force(env, params, state, fog_target)
            got.append(opt.reward)
            want.append(best)
            assert play(opt.plan) == opt.reward, "the plan does not earn the optimum under the plain rules"
            assert team.replay(env, machines, state, opt.plan, fog_target)["total"] == opt.reward
    np.testing.assert_array_equal(got, want)
    assert len(set(want)) >= 2, "a degenerate case tests nothing"


@pytest.mark.parametrize("rules", [dict(reward_when_caught=False), dict(safe_base=True),
                                   dict(capture="opponent_moves")], ids=["not_when_caught", "safe_base", "capture"])
def test_rule_readings_match_brute_force(rules):
    env = DCG(grid_size=3, total_reward=3, history=1, obs_history=False, **rules)
    params = env.make_params(energy=2.0, max_steps=4)
    machines = many_items.opponent_machines(env, params)
    for state in _games(env, params, 12, seed=5):
        assert team.game_optimum(env, machines, state).reward == brute_force(env, params, state, "visible")[0]


def test_fog_readings_differ_somewhere():
    """The two fog readings are different games: the search sees the difference the brute force sees."""
    env = DCG(grid_size=3, total_reward=3, strategies=("with_fog",), history=1, obs_history=False)
    params = env.make_params(energy=2.0, max_steps=4)
    machines = many_items.opponent_machines(env, params)
    diff = 0
    for state in _games(env, params, 16, seed=7):
        a, b = (team.game_optimum(env, machines, state, f).reward for f in team.FOG_TARGETS)
        assert (a, b) == tuple(brute_force(env, params, state, f)[0] for f in team.FOG_TARGETS)
        diff += a != b
    assert diff > 0


def test_targets():
    """Nearest active collector; ties to the lowest index; the fog readings."""
    n = 5
    cells = np.array([[6, 18], [18, 6], [6, 18], [0, 18], [0, 5]])  # (1,1)/(3,3); (0,0)/(3,3); (0,0)/(1,0)
    active = np.array([[True, True], [True, True], [False, True], [True, True], [True, True]])
    q = np.array([12, 12, 7, 1, 24])
    got = team.target_cells(n, q, cells, active, False, None)
    np.testing.assert_array_equal(got, [6, 18, 18, 0, 0])  # ties -> index 0 (rows 0, 1, 4); inactive skipped
    np.testing.assert_array_equal(team.target_cells(n, q, cells, active, False, "visible"), [6, 18, 18, 18, 0])
    np.testing.assert_array_equal(team.target_cells(n, q, cells, active, True, None)[3], 0)


# -- against one collector and in bigger games ---------------------------------------------------------------------
def test_two_collectors_never_earn_less_than_one():
    env = DCG(grid_size=4, total_reward=4, history=1, obs_history=False)
    params = env.make_params(energy=5.0, max_steps=30)
    machines = many_items.opponent_machines(env, params)
    one, two = [], []
    for state in _games(env, params, 30, seed=11):
        one.append(many_items.game_optimum(env, machines, state).reward)
        opt = team.game_optimum(env, machines, state)
        two.append(opt.reward)
        assert team.replay(env, machines, state, opt.plan)["total"] == opt.reward
    one, two = np.array(one), np.array(two)
    assert np.all(two >= one) and np.any(two > one)
    assert np.all(two <= [team.reach_bound(env, params, s) for s in _games(env, params, 30, seed=11)])


def test_sampled_bound():
    env = DCG(grid_size=3, total_reward=3, history=1, obs_history=False)
    params = env.make_params(energy=4.0, max_steps=10)
    res = team.sampled_bound(env, params, jax.random.PRNGKey(0), 40)
    assert res["kind"] == "exact" and res["rewards"].shape == (40,)
    assert res["mean"] == pytest.approx(res["rewards"].mean())
    assert sum(v["episodes"] for v in res["per_strategy"].values()) == 40
    one = many_items.sampled_bound(env, params, jax.random.PRNGKey(0), 40)["rewards"]
    assert np.all(res["rewards"] >= one) and res["mean"] > one.mean()  # the same games
    np.testing.assert_array_equal(team.sampled_bound(env, params, jax.random.PRNGKey(0), 40)["rewards"],
                                  res["rewards"])
    upper = team.sampled_bound(env, params, jax.random.PRNGKey(0), 40, method="upper")
    assert upper["kind"] == "upper_bound" and np.all(upper["rewards"] >= res["rewards"])


def test_the_standard_game_is_refused_and_bounded():
    env = DCG(history=1, obs_history=False)
    params = env.make_params()
    machines = many_items.opponent_machines(env, params)
    state = _games(env, params, 1, seed=1)[0]
    with pytest.raises(ValueError, match="MAX_SEARCH_STATES"):
        team.game_optimum(env, machines, state)
    assert team.search_size(env, machines, state) > team.MAX_SEARCH_STATES
    assert team.reach_bound(env, params, state) == env.total_reward  # every cell is within reach
    auto = team.sampled_bound(env, params, jax.random.PRNGKey(1), 5)
    assert auto["kind"] == "upper_bound" and auto["mean"] == env.total_reward


def test_reach_bound_leaves_out_cells_out_of_reach():
    env = DCG(grid_size=5, total_reward=20, history=1, obs_history=False)
    params = env.make_params(energy=2.0, max_steps=100)
    near = []
    for state in _games(env, params, 5, seed=2):
        near.append(np.asarray(state.items)[:3, :3].sum())  # Chebyshev distance <= 2 from the base
        assert team.reach_bound(env, params, state) == near[-1]
    assert min(near) < env.total_reward
    short = env.make_params(energy=15.0, max_steps=1)
    state = _games(env, short, 1, seed=2)[0]
    assert team.reach_bound(env, short, state) == np.asarray(state.items)[:2, :2].sum()
