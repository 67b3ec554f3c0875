"""The opponent strategies of the DCG (sections 5.5.1, 5.5.7) on hand-made states, and the registry."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.dcg import DCG, EnvState, OpponentState, register_strategy, registered_strategies
from jaxdc.dcg import opponents as opp_lib
from tests.support.states import make_game as game

N = 5
ALL = ("patrol", "restricted", "with_fog", "double_blind")
ENV = DCG(grid_size=N, strategies=ALL, history=2)
CELLS = [(r, c) for r in range(N) for c in range(N)]


def params(tie="straight", **kw):
    return ENV.make_params(chase_tie=tie, **kw)


def all_pairs(strategy):
    """Every (collector, opponent) pair of distinct cells as one batched state (built in numpy: fast)."""
    pairs = [(p, o) for p in CELLS for o in CELLS if p != o]
    b = len(pairs)
    pos = np.array([p for p, _ in pairs], np.int32)
    opp = np.array([o for _, o in pairs], np.int32)
    batch = EnvState(
        pos=pos, energy=np.full(b, 15.0, np.float32), items=np.zeros((b, N, N), np.float32),
        opponent=OpponentState(pos=opp, home=opp, target=opp, phase=np.zeros(b, np.int32)),
        strategy=np.full(b, ENV.strategies.index(strategy), np.int32),
        history=np.zeros((b, N, N, ENV.history), np.float32), time=np.zeros(b, np.int32),
        outcome=np.zeros(b, np.int32), ep_reward=np.zeros(b, np.float32), ep_energy=np.zeros(b, np.int32),
    )
    return pairs, batch


BATCH_MOVE = jax.jit(jax.vmap(ENV.opponent_move, in_axes=(0, 0, None)))


@pytest.fixture(scope="module")
def moves():
    """o_t of every pair, per (strategy, tie) -- one jitted vmap each."""
    fn = BATCH_MOVE
    out = {}
    for strategy in ("restricted", "with_fog"):
        pairs, batch = all_pairs(strategy)
        for tie in ("straight", "order"):
            a, opp = fn(jax.random.split(jax.random.PRNGKey(0), len(pairs)), batch, params(tie))
            out[strategy, tie] = (pairs, np.asarray(a), np.asarray(opp.pos))
    return out


@pytest.mark.parametrize("tie", ["straight", "order"])
def test_restricted_never_diagonal_and_closes_manhattan(moves, tie):
    pairs, a, new = moves["restricted", tie]
    assert np.all(a < 5), "restricted used a diagonal action"
    for (p, o), q in zip(pairs, new):
        assert grid.manhattan(np.array(q), np.array(p)) == grid.manhattan(np.array(o), np.array(p)) - 1


def test_restricted_tie_rules():
    one = jax.jit(ENV.opponent_move)
    k = jax.random.PRNGKey(0)

    def a(p, o, tie):
        return int(one(k, game(ENV, p, o, "restricted"), params(tie))[0])

    assert a((0, 0), (4, 3), "straight") == 1  # larger (row) gap first: up
    assert a((0, 0), (3, 4), "straight") == 3  # larger (column) gap first: left
    assert a((0, 0), (3, 4), "order") == 1  # first of the best in thesis order: up
    assert a((0, 0), (4, 4), "straight") == 1  # equal gaps: rows first


@pytest.mark.parametrize("tie", ["straight", "order"])
def test_with_fog_stays_in_fog_and_chases_otherwise(moves, tie):
    pairs, a, _ = moves["with_fog", tie]
    rule = {"straight": "diagonal", "order": "order"}[tie]
    for (p, o), act in zip(pairs, a):
        if p[0] == 0 or p[1] == 0:
            assert act == grid.STAY, (p, o)
        else:  # all 9 actions: exactly grid.shortest_move
            assert act == int(grid.shortest_move(jnp.array(o), jnp.array(p), N, rule)), (p, o)
    assert np.any(a >= 5), "with_fog never moved diagonally"


def test_double_blind_moves_like_with_fog():
    fn = BATCH_MOVE
    pairs, wf = all_pairs("with_fog")
    _, db = all_pairs("double_blind")
    keys = jax.random.split(jax.random.PRNGKey(1), len(pairs))
    np.testing.assert_array_equal(fn(keys, wf, params())[0], fn(keys, db, params())[0])


def test_random_tie_uses_all_best_moves_only():
    s = game(ENV, (0, 0), (3, 4), "restricted")
    fn = jax.jit(jax.vmap(ENV.opponent_move, in_axes=(0, None, None)))
    a = np.asarray(fn(jax.random.split(jax.random.PRNGKey(2), 200), s, params("random"))[0])
    assert set(a.tolist()) == {1, 3}  # up and left both close the Manhattan gap


def test_patrol_turns_around_at_both_ends():
    env = DCG(grid_size=N, strategies=("patrol",), history=1)
    p = env.make_params()
    s = game(env, (0, 0), (2, 2), "patrol", items={(4, 0): 1}, home=(2, 2), target=(2, 4))
    step = jax.jit(env.step_env)
    path = []
    for t in range(9):
        _, s, _, term, _, info = step(jax.random.PRNGKey(t), s, jnp.int32(grid.STAY), p)
        assert not term
        path.append(tuple(np.asarray(s.opponent.pos).tolist()))
    assert path == [(2, 3), (2, 4), (2, 3), (2, 2), (2, 3), (2, 4), (2, 3), (2, 2), (2, 3)]


def test_patrol_follows_a_shortest_path():
    env = DCG(grid_size=N, strategies=("patrol",), history=1)
    p = env.make_params()
    s = game(env, (0, 0), (4, 4), "patrol", items={(4, 0): 1}, home=(4, 4), target=(1, 2))
    step = jax.jit(env.step_env)
    path = [(4, 4)]
    for t in range(6):
        _, s, _, _, _, info = step(jax.random.PRNGKey(t), s, jnp.int32(grid.STAY), p)
        path.append(tuple(np.asarray(s.opponent.pos).tolist()))
    assert path == [(4, 4), (3, 3), (2, 2), (1, 2), (2, 3), (3, 4), (4, 4)]  # diagonal while both axes differ


def test_patrol_with_home_equal_target_stays():
    s = game(ENV, (0, 0), (3, 3), "patrol", home=(3, 3), target=(3, 3))
    a, _ = jax.jit(ENV.opponent_move)(jax.random.PRNGKey(0), s, params())
    assert int(a) == grid.STAY


def test_register_custom_strategy_without_touching_the_env():
    def always_down(key, opp, g, prm):
        return jnp.int32(2), opp.replace(phase=opp.phase + 1)

    if "test_always_down" not in registered_strategies():
        register_strategy("test_always_down", always_down)
    with pytest.raises(ValueError, match="already registered"):
        register_strategy("test_always_down", always_down)
    env = DCG(strategies=("test_always_down",), history=1)
    s = game(env, (0, 0), (1, 3), "test_always_down")
    _, s2, _, _, _, info = jax.jit(env.step_env)(jax.random.PRNGKey(0), s, jnp.int32(0), env.default_params)
    assert int(info["opponent_action"]) == 2 and tuple(np.asarray(s2.opponent.pos)) == (2, 3)
    assert int(s2.opponent.phase) == 1


@pytest.mark.parametrize("bad", [(), [], "", ("patrol", "nope"), ("patrol", "patrol")])
def test_bad_strategy_sets(bad):
    with pytest.raises(ValueError, match="strategies") as e:
        DCG(strategies=bad)
    if bad == ("patrol", "nope"):
        assert "'nope'" in str(e.value) and "with_fog" in str(e.value)  # lists the registered names


def test_strategy_set_from_comma_string():
    assert DCG(strategies="patrol, restricted").strategies == ("patrol", "restricted")


def test_in_fog():
    fog = np.array([[bool(opp_lib.in_fog(jnp.array([r, c]))) for c in range(N)] for r in range(N)])
    expected = np.zeros((N, N), bool)
    expected[0, :] = expected[:, 0] = True
    np.testing.assert_array_equal(fog, expected)
