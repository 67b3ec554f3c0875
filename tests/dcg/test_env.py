"""The DCG environment (section 5.3): step order, energy, fog, history, batching, the strategy draw, bad input."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from jaxdc.core import grid
from jaxdc.dcg import DCG
from jaxdc.dcg.env import CAUGHT, CLEARED, ENERGY, OUTCOMES, RUNNING, TRUNCATED
from tests.support.states import make_game

N = 5
ENV = DCG(grid_size=N, strategies=("patrol", "restricted", "with_fog", "double_blind"), history=3)
P = ENV.default_params
STEP = jax.jit(ENV.step_env)
STAY, UP, DOWN, LEFT, RIGHT, UP_LEFT = 0, 1, 2, 3, 4, 5


def game(pos, opp, strategy="patrol", items=None, energy=15.0, home=None, target=None, env=ENV):
    """A hand-made state (one unit item at (4, 0) by default); ``patrol`` with ``home == target`` never moves."""
    return make_game(env, pos, opp, strategy, {(4, 0): 1.0} if items is None else items, energy, home, target)


def step(s, a, env=ENV, params=P, seed=0):
    fn = STEP if env is ENV else jax.jit(env.step_env)
    return fn(jax.random.PRNGKey(seed), s, jnp.int32(a), params)


# -- the order of a step -----------------------------------------------------------------------


def test_opponent_moves_first_and_catches_before_the_collector_moves():
    # restricted opponent at (1,2) steps left onto the collector at (1,1); the collector's "right"
    # (into the cell the opponent left, which holds an item) never happens.
    s = game((1, 1), (1, 2), "restricted", items={(1, 2): 1.0, (4, 4): 1.0})
    _, s2, r, term, trunc, info = step(s, RIGHT)
    assert int(info["opponent_action"]) == LEFT
    assert bool(term) and not bool(trunc) and int(info["outcome"]) == CAUGHT
    assert tuple(np.asarray(s2.pos)) == (1, 1) and float(r) == 0.0 and float(s2.items[1, 2]) == 1.0


def test_swapping_cells_is_not_a_catch():
    # patrol from (2,2) to (2,4) steps right to (2,3); the collector steps from (2,1) into (2,2).
    s = game((2, 1), (2, 2), "patrol", home=(2, 2), target=(2, 4))
    _, s2, _, term, _, info = step(s, RIGHT)
    assert not bool(term) and int(info["outcome"]) == RUNNING
    assert tuple(np.asarray(s2.pos)) == (2, 2) and tuple(np.asarray(s2.opponent.pos)) == (2, 3)


@pytest.mark.parametrize("counts", [True, False])
def test_collector_walking_into_the_opponent_is_caught_and_item_rule(counts):
    env = DCG(grid_size=N, strategies=ENV.strategies, history=3, reward_when_caught=counts)
    s = game((2, 2), (3, 3), "patrol", items={(3, 2): 1.0, (4, 4): 1.0}, home=(3, 3), target=(3, 1), env=env)
    _, s2, r, term, _, info = step(s, DOWN, env=env, params=env.default_params)
    assert tuple(np.asarray(s2.opponent.pos)) == (3, 2) and tuple(np.asarray(s2.pos)) == (3, 2)
    assert bool(term) and int(info["outcome"]) == CAUGHT
    assert float(r) == (1.0 if counts else 0.0) and float(info["episode_reward"]) == float(r)


# -- energy, base, termination -----------------------------------------------------------------


def test_energy_drops_outside_and_refills_in_base():
    s = game((1, 1), (4, 4), energy=7.0)
    _, s2, _, term, _, info = step(s, RIGHT)
    assert float(s2.energy) == 6.0 and not bool(term) and int(info["episode_energy"]) == 1
    _, s3, _, term, _, _ = step(s, UP_LEFT)
    assert float(s3.energy) == 15.0 and tuple(np.asarray(s3.pos)) == (0, 0) and not bool(term)


def test_energy_zero_disables():
    _, s2, _, term, _, info = step(game((1, 1), (4, 4), energy=1.0), RIGHT)
    assert float(s2.energy) == 0.0 and bool(term) and int(info["outcome"]) == ENERGY
    _, s3, _, term, _, _ = step(game((1, 1), (4, 4), energy=1.0), UP_LEFT)  # reaching the base saves it
    assert float(s3.energy) == 15.0 and not bool(term)


def test_cleared_and_truncated():
    _, s2, r, term, _, info = step(game((3, 1), (2, 4)), DOWN_LEFT := 7)
    assert float(r) == 1.0 and bool(term) and int(info["outcome"]) == CLEARED
    p1 = ENV.make_params(max_steps=1)
    _, _, _, term, trunc, info = step(game((1, 1), (4, 4)), STAY, params=p1)
    assert not bool(term) and bool(trunc) and int(info["outcome"]) == TRUNCATED


def test_reset_rules():
    keys = jax.random.split(jax.random.PRNGKey(0), 500)
    _, s = jax.jit(jax.vmap(ENV.reset_env, in_axes=(0, None)))(keys, ENV.make_params(energy=20.0))
    assert np.all(np.asarray(s.pos) == 0) and np.all(np.asarray(s.energy) == 20.0)
    assert np.all(np.asarray(s.items).sum(axis=(1, 2)) == 10)
    opp, target = np.asarray(s.opponent.pos), np.asarray(s.opponent.target)
    assert np.all(opp.sum(-1) > 0), "opponent started on the base"
    assert np.all(target.sum(-1) > 0) and np.all(np.any(target != opp, -1)), "bad patrol target"
    assert np.all(np.asarray(s.opponent.home) == opp) and np.all(np.asarray(s.history) == 0)
    assert len({tuple(o) for o in opp}) == N * N - 1  # every non-base cell occurs


# -- the reward area (section 5.5.5, Figs. 5.10-5.12) -------------------------------------------


@pytest.mark.parametrize("size", [1, 2, 3, 4, 5])
def test_reward_area_places_one_unit_item_uniformly_in_the_bottom_right_square(size):
    env = DCG(grid_size=N, reward_area=size, history=2)
    assert env.total_reward == 1 and env.reward_area == size
    keys = jax.random.split(jax.random.PRNGKey(size), 3000)
    _, s = jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(keys, env.default_params)
    items = np.asarray(s.items).reshape(len(keys), -1)
    assert np.all(items.sum(-1) == 1.0) and np.all(items.max(-1) == 1.0)
    r, c = np.divmod(items.argmax(-1), N)
    assert np.all(r >= N - size) and np.all(c >= N - size)
    counts = np.bincount(items.argmax(-1), minlength=N * N)[env.reward_area_cells()]
    assert counts.size == size * size and np.all(counts > 0)
    if size > 1:
        assert stats.chisquare(counts).pvalue > 1e-3, counts
    # the opponent's start is drawn as without a reward area (never the base, may be the item's cell)
    assert np.all(np.asarray(s.opponent.pos).sum(-1) > 0)


def test_reward_area_cells_and_more_units():
    assert DCG(grid_size=4, reward_area=2).reward_area_cells().tolist() == [10, 11, 14, 15]
    assert DCG(grid_size=3, reward_area=3).reward_area_cells().tolist() == list(range(9))
    assert DCG(grid_size=3, reward_area=3, items_on_base=False).reward_area_cells().tolist() == list(range(1, 9))
    assert DCG(grid_size=3).reward_area_cells(1).tolist() == [8]
    assert DCG().total_reward == 10 and DCG(reward_area=None).reward_area is None
    assert DCG(reward_area=2) != DCG() and DCG(reward_area=2) == DCG(reward_area=2)
    env = DCG(grid_size=4, reward_area=2, total_reward=7, history=2)
    _, s = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(jax.random.PRNGKey(1), 200), env.default_params)
    items = np.asarray(s.items)
    assert np.all(items.sum(axis=(1, 2)) == 7) and np.all(items[:, :2, :] == 0) and np.all(items[:, :, :2] == 0)
    with pytest.raises(ValueError, match="reward_area"):
        DCG(grid_size=3).reward_area_cells(4)
    with pytest.raises(TypeError, match="reward_area"):
        DCG(reward_area=2.0)


def test_min_reward_area_mixes_sizes_uniformly_then_cells_uniformly():
    """Each episode draws its square's size uniformly from m..S, then the item uniformly in that square, so a
    cell's probability is the mean over sizes of 1/size^2 for the sizes whose square holds it."""
    env = DCG(grid_size=N, reward_area=4, min_reward_area=2, history=2)
    assert "min_reward_area=2" in repr(env) and env != DCG(grid_size=N, reward_area=4, history=2)
    keys = jax.random.split(jax.random.PRNGKey(7), 20000)
    _, s = jax.jit(jax.vmap(env.reset_env, in_axes=(0, None)))(keys, env.default_params)
    items = np.asarray(s.items).reshape(len(keys), -1)
    assert np.all(items.sum(-1) == 1.0)
    r, c = np.divmod(np.arange(N * N), N)
    expected = np.zeros(N * N)
    for size in (2, 3, 4):
        inside = (r >= N - size) & (c >= N - size)
        expected[inside] += 1.0 / (3 * size * size)
    counts = np.bincount(items.argmax(-1), minlength=N * N)
    assert np.all(counts[expected == 0] == 0)
    assert stats.chisquare(counts[expected > 0], expected[expected > 0] * len(keys)).pvalue > 1e-3
    # several units per episode all land in the episode's one square
    env = DCG(grid_size=N, reward_area=3, min_reward_area=1, total_reward=4, history=2)
    _, s = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(jax.random.PRNGKey(2), 500), env.default_params)
    items = np.asarray(s.items)
    assert np.all(items.sum(axis=(1, 2)) == 4)
    rows, cols = np.nonzero(items.sum(0))
    assert rows.min() >= N - 3 and cols.min() >= N - 3


@pytest.mark.parametrize("kwargs, error, message", [
    ({"min_reward_area": 1}, ValueError, "needs a reward_area"),
    ({"reward_area": 2, "min_reward_area": 3}, ValueError, r"between 1 and reward_area \(2\), got 3"),
    ({"reward_area": 2, "min_reward_area": 0}, ValueError, "min_reward_area"),
    ({"reward_area": 2, "min_reward_area": 1.5}, TypeError, "min_reward_area"),
])
def test_min_reward_area_refuses_bad_values(kwargs, error, message):
    with pytest.raises(error, match=message):
        DCG(grid_size=N, **kwargs)


# -- observations: fog and history ------------------------------------------------------------


@pytest.mark.parametrize("strategy,hidden", [("with_fog", False), ("double_blind", True)])
def test_fog_visibility(strategy, hidden):
    s = game((0, 2), (3, 3), strategy, energy=9.0)
    plane = np.asarray(ENV.agent_plane(s, P))
    assert plane[0, 2] == 9.0
    assert plane[3, 3] == (0.0 if hidden else -1.0)
    assert ("~" in ENV.render_ansi(s, P)) == hidden and ("O" in ENV.render_ansi(s, P)) is True
    out_of_fog = game((1, 2), (3, 3), strategy)
    assert np.asarray(ENV.agent_plane(out_of_fog, P))[3, 3] == -1.0  # visible outside the fog either way


def test_history_shifts_newest_first():
    s = game((2, 2), (4, 4))
    planes = [np.asarray(ENV.agent_plane(s, P))]
    for a in (RIGHT, DOWN, LEFT):
        obs, s, _, term, _, _ = step(s, a)
        assert not bool(term)
        h = np.asarray(s.history)
        for j in range(ENV.history):
            want = planes[-1 - j] if j < len(planes) else np.zeros((N, N))
            np.testing.assert_array_equal(h[..., j], want)
        planes.append(np.asarray(ENV.agent_plane(s, P)))
        np.testing.assert_array_equal(np.asarray(obs)[..., 2:], h)
        np.testing.assert_array_equal(np.asarray(obs)[..., 1], planes[-1])
    assert obs.shape == (N, N, 2 + ENV.history)


def test_history_keeps_what_the_collector_saw():
    s = game((1, 2), (4, 4), "double_blind")
    _, s2, _, _, _, _ = step(s, UP)  # (1,2) -> (0,2): fog; the opponent moved while visible
    assert np.asarray(s2.history)[..., 0].min() == -1.0  # the old plane showed it
    _, s3, _, _, _, _ = step(s2, RIGHT)  # still in the fog: the stored plane hides it
    assert np.asarray(s3.history)[..., 0].min() == 0.0


def test_history_fill_first_and_no_history_obs():
    env = DCG(history=4, history_fill="first")
    obs, s = env.reset(jax.random.PRNGKey(3))
    assert obs.shape == (5, 5, 6)
    for j in range(4):
        np.testing.assert_array_equal(obs[..., 2 + j], obs[..., 1])
    env2 = DCG(obs_history=False)
    assert env2.reset(jax.random.PRNGKey(3))[0].shape == (5, 5, 2) == env2.observation_shape()


# -- batching, determinism, the strategy draw ------------------------------------------------------


def test_jit_vmap_equals_python_loop():
    env, p, b, t = DCG(history=2), DCG(history=2).make_params(max_steps=3), 4, 5
    keys = jax.random.split(jax.random.PRNGKey(7), b)
    acts = np.random.default_rng(0).integers(0, 9, (t, b)).astype(np.int32)
    step_keys = jax.random.split(jax.random.PRNGKey(8), t * b).reshape(t, b, 2)
    vreset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
    vstep = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    obs, s = vreset(keys, p)
    batched = []
    for i in range(t):
        obs, s, r, te, tr, info = vstep(step_keys[i], s, acts[i], p)
        batched.append((obs, r, te, tr, info["opponent_action"], info["strategy"]))
    one_step = jax.jit(env.step)
    for g in range(b):
        o, sg = jax.jit(env.reset)(keys[g], p)
        for i in range(t):
            o, sg, r, te, tr, info = one_step(step_keys[i, g], sg, jnp.int32(acts[i, g]), p)
            want = (o, r, te, tr, info["opponent_action"], info["strategy"])
            for x, y in zip(want, batched[i]):
                np.testing.assert_allclose(np.asarray(x), np.asarray(y)[g])
    assert np.any(np.stack([np.asarray(x[2]) | np.asarray(x[3]) for x in batched])), "no auto-reset exercised"


def test_scan_over_16384_games():
    env = DCG()
    p = env.default_params
    b = 16384

    @jax.jit
    def run(key):
        obs, s = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, b), p)

        def body(carry, k):
            s = carry
            ka, ks = jax.random.split(k)
            a = jax.random.randint(ka, (b,), 0, 9)
            obs, s, r, te, tr, info = jax.vmap(env.step, in_axes=(0, 0, 0, None))(jax.random.split(ks, b), s, a, p)
            return s, (r.sum(), te.sum(), info["opponent_action"].max())

        return jax.lax.scan(body, s, jax.random.split(key, 3))

    s, (r, te, oa) = run(jax.random.PRNGKey(0))
    assert s.history.shape == (b, 5, 5, 10) and np.all(np.asarray(oa) < 9) and np.asarray(te).sum() > 0


def test_determinism_by_seed():
    obs1, s1 = jax.jit(ENV.reset)(jax.random.PRNGKey(11), P)
    obs2, s2 = jax.jit(ENV.reset)(jax.random.PRNGKey(11), P)
    obs3, _ = jax.jit(ENV.reset)(jax.random.PRNGKey(12), P)
    for x, y in zip(jax.tree_util.tree_leaves(s1), jax.tree_util.tree_leaves(s2)):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(obs1, obs3)
    a = STEP(jax.random.PRNGKey(5), s1, jnp.int32(4), P)
    b = STEP(jax.random.PRNGKey(5), s2, jnp.int32(4), P)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(x, y)


def test_strategy_draw_is_uniform():
    keys = jax.random.split(jax.random.PRNGKey(2024), 4000)
    _, s = jax.jit(jax.vmap(ENV.reset_env, in_axes=(0, None)))(keys, P)
    counts = np.bincount(np.asarray(s.strategy), minlength=4)
    assert counts.sum() == 4000 and len(counts) == 4
    assert stats.chisquare(counts).pvalue > 1e-3, counts


# -- bad input ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs,name",
    [({"grid_size": 1}, "grid_size"), ({"history": 0}, "history"), ({"total_reward": 0}, "total_reward"),
     ({"strategies": ()}, "strategies"), ({"strategies": ("nope",)}, "strategies"),
     ({"history_fill": "x"}, "history_fill"), ({"opponent_start": "x"}, "opponent_start"),
     ({"patrol_target": "x"}, "patrol_target"), ({"energy_metric": "x"}, "energy_metric"),
     ({"reward_area": 0}, "reward_area"), ({"reward_area": 6}, "reward_area"),
     ({"reward_area": 2, "total_reward": 0}, "total_reward")],
)
def test_bad_config(kwargs, name):
    with pytest.raises(ValueError, match=name):
        DCG(**kwargs)


@pytest.mark.parametrize(
    "kwargs,name",
    [({"energy": 0}, "energy"), ({"energy": -3.0}, "energy"), ({"energy": float("nan")}, "energy"),
     ({"max_steps": 0}, "max_steps"), ({"chase_tie": "x"}, "chase_tie")],
)
def test_bad_params(kwargs, name):
    with pytest.raises(ValueError, match=name):
        ENV.make_params(**kwargs)


def test_config_equality_and_outcomes():
    assert DCG() == DCG() and hash(DCG()) == hash(DCG()) and DCG() != DCG(history=3)
    assert OUTCOMES == ("running", "caught", "energy", "cleared", "truncated")
    assert ENV.num_actions == grid.NUM_ACTIONS == 9


@pytest.mark.parametrize("reading,energy_left,counted", [("charged", 4.0, 1), ("uncharged", 5.0, 0)])
def test_caught_energy_reading(reading, energy_left, counted):
    """Rule (1) catches the collector before it moves: one unit charged, or the step ends before the energy rule."""
    env = DCG(grid_size=3, strategies=("restricted",), caught_energy=reading)
    params = env.make_params(energy=8.0)
    state = make_game(env, pos=(1, 1), opp=(1, 2), strategy="restricted", items={(2, 2): 1.0}, energy=5.0)
    _, s2, _, terminated, _, info = env.step_env(jax.random.PRNGKey(0), state, 4, params)
    assert bool(terminated) and int(s2.outcome) == CAUGHT
    assert float(s2.energy) == energy_left and int(info["episode_energy"]) == counted


def test_safe_base_and_opponent_out_of_base():
    env = DCG(grid_size=3, strategies=("restricted",), safe_base=True)
    params = env.make_params(energy=8.0)
    # the chaser steps into the base
    state = make_game(env, pos=(0, 0), opp=(0, 1), strategy="restricted", items={(2, 2): 1.0})
    _, s2, *_ = env.step_env(jax.random.PRNGKey(0), state, 0, params)  # stay: not caught in the base
    assert int(s2.outcome) == RUNNING and tuple(np.asarray(s2.opponent.pos)) == (0, 0)
    plain = DCG(grid_size=3, strategies=("restricted",))
    assert int(plain.step_env(jax.random.PRNGKey(0), make_game(plain, (0, 0), (0, 1), "restricted"), 0,
                              params)[1].outcome) == CAUGHT
    barred = DCG(grid_size=3, strategies=("restricted",), opponent_enters_base=False)
    _, s3, _, _, _, info = barred.step_env(
        jax.random.PRNGKey(0), make_game(barred, (0, 0), (0, 1), "restricted", {(2, 2): 1.0}), 0, params)
    assert tuple(np.asarray(s3.opponent.pos)) == (0, 1) and int(info["opponent_action"]) == grid.STAY
    assert int(s3.outcome) == RUNNING


@pytest.mark.parametrize("kwargs,match", [
    (dict(capture="never"), "capture must be one of"),
    (dict(caught_energy="half"), "caught_energy must be one of"),
    (dict(safe_base=1), "safe_base must be a bool"),
    (dict(obs_history="no"), "obs_history must be a bool .*got 'no'"),
    (dict(items_on_base=1), "items_on_base must be a bool"),
    (dict(reward_when_caught="yes"), "reward_when_caught must be a bool"),
    (dict(opponent_enters_base="no"), "opponent_enters_base must be a bool"),
    (dict(opponent_enters_base=False, opponent_start="any"), "needs opponent_start='not_base'"),
])
def test_rule_readings_bad_input(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        DCG(**kwargs)
