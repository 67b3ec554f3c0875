"""The team DCG (jaxdc.dcg.team.env): identical to the DCG with one collector and one opponent, and the
new rules on hand-built states (docs/dcg.md, "The team game")."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid
from jaxdc.dcg.env import CAUGHT, CLEARED, DCG, ENERGY, RUNNING, EnvState
from jaxdc.dcg.team import DCGTeam, TeamState

STEPS, LANES = 200, 16


def _play_both(options, params_kwargs=None, steps=STEPS, lanes=LANES, seed=0):
    """Random play through DCG and DCGTeam(k=1, m=1) from the same keys; every per-step output, stacked."""
    single = DCG(**options)
    team = DCGTeam(collectors=1, opponents=1, **options)
    params = single.make_params(**(params_kwargs or {}))

    def run(env, stacked):
        def lane(key):
            k_reset, k_loop = jax.random.split(key)
            obs, state = env.reset(k_reset, params)

            def body(carry, key):
                obs, state = carry
                k_act, k_step = jax.random.split(key)
                a = jax.random.randint(k_act, (), -1, 10)  # a few invalid actions too
                obs2, state2, r, term, trunc, info = env.step(k_step, state, a[None] if stacked else a, params)
                return (obs2, state2), (obs2, state2, r, term, trunc, info)

            return (obs, state), jax.lax.scan(body, (obs, state), jax.random.split(k_loop, steps))[1]

        return jax.jit(jax.vmap(lane))(jax.random.split(jax.random.PRNGKey(seed), lanes))

    return run(single, False), run(team, True)


def _assert_same(one, team):
    (obs0, st0), (obs, st, r, term, trunc, info) = one
    (tobs0, tst0), (tobs, tst, tr, tterm, ttrunc, tinfo) = team
    np.testing.assert_array_equal(np.asarray(obs0), np.asarray(tobs0)[:, 0])
    np.testing.assert_array_equal(np.asarray(obs), np.asarray(tobs)[:, :, 0])
    np.testing.assert_array_equal(np.asarray(r), np.asarray(tr))
    np.testing.assert_array_equal(np.asarray(term), np.asarray(tterm))
    np.testing.assert_array_equal(np.asarray(trunc), np.asarray(ttrunc))
    for initial, a, b in ((True, st0, tst0), (False, st, tst)):
        lead = 1 if initial else 2  # [lanes] or [lanes, steps]
        def pick(x, lead=lead):
            return np.asarray(x)[(slice(None),) * lead + (0,)]
        pairs = {"pos": (a.pos, pick(b.pos)), "energy": (a.energy, pick(b.energy)),
                 "outcome_collector": (a.outcome, pick(b.collector_outcome)), "items": (a.items, b.items),
                 "strategy": (a.strategy, pick(b.strategy)), "history": (a.history, pick(b.history)),
                 "time": (a.time, b.time), "outcome": (a.outcome, b.outcome), "ep_reward": (a.ep_reward, b.ep_reward),
                 "ep_energy": (a.ep_energy, b.ep_energy), "max_energy": (a.max_energy, b.max_energy)}
        for f in dataclasses.fields(a.opponent):
            pairs[f"opponent.{f.name}"] = (getattr(a.opponent, f.name), pick(getattr(b.opponent, f.name)))
        for name, (x, y) in pairs.items():
            if x is None:
                assert y is None, name
                continue
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y), err_msg=name)
    assert set(info) <= set(tinfo)
    for key in ("outcome", "episode_reward", "episode_energy", "episode_steps"):
        np.testing.assert_array_equal(np.asarray(info[key]), np.asarray(tinfo[key]), err_msg=key)
    for key in ("opponent_action", "strategy", "invalid_action"):
        np.testing.assert_array_equal(np.asarray(info[key]), np.asarray(tinfo[key])[:, :, 0], err_msg=key)
    np.testing.assert_array_equal(np.asarray(info["final_observation"]),
                                  np.asarray(tinfo["final_observation"])[:, :, 0])
    np.testing.assert_array_equal(np.asarray(r), np.asarray(tinfo["collector_rewards"])[:, :, 0])
    # the play really ended episodes (several outcomes) and collected items
    outcomes = set(np.unique(np.asarray(info["outcome"])).tolist())
    assert len(outcomes) >= 3, outcomes
    assert float(np.asarray(r).sum()) > 0


@pytest.mark.parametrize("options,params_kwargs", [
    ({}, None),
    ({"strategies": ("patrol", "restricted", "double_blind")}, None),
    ({"observation": "general"}, {"energy_range": (5, 20)}),
    ({"capture": "opponent_moves", "caught_energy": "uncharged", "history_fill": "first"},
     {"chase_tie": "random"}),
    ({"safe_base": True, "opponent_enters_base": False, "reward_when_caught": False, "obs_history": False},
     {"energy": 8.0, "max_steps": 30}),
], ids=["standard", "double_blind", "general_energy_range", "rules_a", "rules_b"])
def test_one_collector_one_opponent_is_the_dcg(options, params_kwargs):
    one, team = _play_both(options, params_kwargs)
    _assert_same(one, team)


# -- the new rules on hand-built states ---------------------------------------------------------------------

def _state(env, params, pos, *, opp=((4, 4),), items=None, outcome=None, energy=None, strategy=None, seed=0):
    """A reset state with the collectors at ``pos``, the opponents at ``opp``, and the given fields."""
    _, s = env.reset(jax.random.PRNGKey(seed), params)
    n = env.grid_size
    k, m = env.collectors, env.opponents
    opp = jnp.asarray(opp, jnp.int32)
    fields = {"pos": jnp.asarray(pos, jnp.int32),
              "opponent": s.opponent.replace(pos=opp, home=opp, target=opp, phase=jnp.zeros(m, jnp.int32)),
              "strategy": jnp.zeros(m, jnp.int32) if strategy is None else jnp.asarray(strategy, jnp.int32)}
    if items is not None:
        grid_items = np.zeros((n, n), np.float32)
        for (r, c), v in items.items():
            grid_items[r, c] = v
        fields["items"] = jnp.asarray(grid_items)
    if outcome is not None:
        fields["collector_outcome"] = jnp.asarray(outcome, jnp.int32)
    if energy is not None:
        fields["energy"] = jnp.asarray(energy, jnp.float32)
    assert fields["pos"].shape == (k, 2)
    return s.replace(**fields)


def _step(env, params, state, actions, seed=1):
    return env.step_env(jax.random.PRNGKey(seed), state, jnp.asarray(actions, jnp.int32), params)


def test_the_restricted_chaser_targets_the_nearest_active_collector_lowest_index_on_a_tie():
    from jaxdc.dcg.team.targeting import target_of

    env = DCGTeam(collectors=3, strategies=("restricted",))
    params = env.make_params()
    far = {(4, 0): 1.0}
    # Manhattan from (2, 2): collector 0 at (0, 2) and collector 1 at (2, 4) are both 2 away, collector 2 is 4
    s = _state(env, params, [(0, 2), (2, 4), (4, 4)], opp=[(2, 2)], items=far)
    assert int(target_of(env, s, 0)) == 0
    _, s2, *_ = _step(env, params, s, [0, 0, 0])
    assert tuple(np.asarray(s2.opponent.pos[0])) == (1, 2)  # one step up, towards collector 0
    # collector 0 disabled: it is ignored, collector 1 is the target
    s = s.replace(collector_outcome=jnp.asarray([CAUGHT, RUNNING, RUNNING], jnp.int32))
    assert int(target_of(env, s, 0)) == 1
    _, s2, *_ = _step(env, params, s, [0, 0, 0])
    assert tuple(np.asarray(s2.opponent.pos[0])) == (2, 3)


def test_distance_counts_the_strategys_moves():
    from jaxdc.dcg.team.targeting import target_of

    # from (2, 2): collector 0 at (4, 4) is 2 Chebyshev / 4 Manhattan moves away, collector 1 at (2, 4) is 2 / 2
    for strategies, want in ((("restricted",), 1), (("with_fog",), 0)):
        env = DCGTeam(collectors=2, strategies=strategies)
        s = _state(env, env.make_params(), [(4, 4), (2, 4)], opp=[(2, 2)])
        assert int(target_of(env, s, 0)) == want, strategies


@pytest.mark.parametrize("fog_target,moved_to", [("visible", (2, 3)), ("nearest", (1, 2))])
def test_fog_targeting_both_readings(fog_target, moved_to):
    env = DCGTeam(collectors=2, strategies=("with_fog",), fog_target=fog_target)
    params = env.make_params()
    # collector 0 in the fog (row 0) one move away, collector 1 visible at (4, 4), three moves away
    s = _state(env, params, [(0, 2), (4, 4)], opp=[(1, 2)], items={(3, 0): 1.0})
    _, s2, *_ = _step(env, params, s, [0, 0])
    assert tuple(np.asarray(s2.opponent.pos[0])) == moved_to
    # every active collector in the fog: both readings stay
    s = _state(env, params, [(0, 2), (4, 4)], opp=[(1, 2)], items={(3, 0): 1.0},
               outcome=[RUNNING, CAUGHT])
    _, s2, *_ = _step(env, params, s, [0, 0])
    assert tuple(np.asarray(s2.opponent.pos[0])) == (1, 2)


def test_two_collectors_on_one_item_cell_the_lowest_index_takes_it_once():
    env = DCGTeam(collectors=3, strategies=("patrol",))
    params = env.make_params()
    s = _state(env, params, [(0, 1), (1, 0), (1, 2)], opp=[(4, 4)], items={(1, 1): 2.0, (3, 3): 1.0})
    down, right, left = grid.ACTIONS.index("down"), grid.ACTIONS.index("right"), grid.ACTIONS.index("left")
    _, s2, reward, term, _, info = _step(env, params, s, [down, right, left])
    assert np.all(np.asarray(s2.pos) == 1)
    assert float(reward) == 2.0
    np.testing.assert_array_equal(np.asarray(info["collector_rewards"]), [2.0, 0.0, 0.0])
    assert float(s2.items[1, 1]) == 0.0 and float(s2.items[3, 3]) == 1.0
    assert float(s2.ep_reward) == 2.0 and not bool(term)


def test_one_caught_collector_the_other_goes_on():
    env = DCGTeam(collectors=2, strategies=("restricted",))
    params = env.make_params()
    # the opponent at (2, 2) steps onto collector 0 at (2, 3) (rule 1); collector 1 moves and collects
    s = _state(env, params, [(2, 3), (0, 3)], opp=[(2, 2)], items={(0, 4): 1.0, (4, 0): 1.0})
    right = grid.ACTIONS.index("right")
    _, s2, reward, term, trunc, info = _step(env, params, s, [right, right])
    np.testing.assert_array_equal(np.asarray(s2.collector_outcome), [CAUGHT, RUNNING])
    np.testing.assert_array_equal(np.asarray(info["collector_outcomes"]), [CAUGHT, RUNNING])
    assert tuple(np.asarray(s2.pos[0])) == (2, 3)  # caught before moving
    assert tuple(np.asarray(s2.pos[1])) == (0, 4) and float(reward) == 1.0
    assert not bool(term) and not bool(trunc) and int(s2.outcome) == RUNNING
    # the next step the chaser ignores collector 0 and heads for collector 1
    _, s3, *_ = _step(env, params, s2, [0, 0])
    assert tuple(np.asarray(s3.opponent.pos[0])) == (1, 3)


def test_the_episode_terminates_when_every_collector_is_disabled():
    env = DCGTeam(collectors=2, strategies=("restricted",))
    params = env.make_params()
    # collector 1 already out of energy; collector 0 gets caught: outcome caught
    s = _state(env, params, [(2, 3), (0, 3)], opp=[(2, 2)], items={(4, 0): 1.0}, outcome=[RUNNING, ENERGY])
    _, s2, _, term, _, info = _step(env, params, s, [0, 0])
    assert bool(term) and int(info["outcome"]) == CAUGHT
    # collector 0 already caught; collector 1 runs out of energy away from the base: outcome energy
    s = _state(env, params, [(2, 3), (4, 4)], opp=[(0, 0)], items={(4, 0): 1.0}, outcome=[CAUGHT, RUNNING],
               energy=[5.0, 1.0])
    _, s2, _, term, _, info = _step(env, params, s, [0, 0])
    assert bool(term) and int(info["outcome"]) == ENERGY
    np.testing.assert_array_equal(np.asarray(s2.collector_outcome), [CAUGHT, ENERGY])


def test_the_episode_terminates_when_every_item_is_collected():
    env = DCGTeam(collectors=2, strategies=("patrol",))
    params = env.make_params()
    s = _state(env, params, [(0, 1), (3, 3)], opp=[(4, 0)], items={(0, 2): 1.0})
    _, s2, reward, term, _, info = _step(env, params, s, [grid.ACTIONS.index("right"), 0])
    assert bool(term) and int(info["outcome"]) == CLEARED and float(reward) == 1.0
    np.testing.assert_array_equal(np.asarray(s2.collector_outcome), [RUNNING, RUNNING])


def test_each_collector_refills_in_the_base_or_spends_one_unit():
    env = DCGTeam(collectors=2, strategies=("patrol",))
    params = env.make_params(energy=15.0)
    s = _state(env, params, [(0, 1), (3, 3)], opp=[(4, 0)], items={(2, 2): 1.0}, energy=[4.0, 9.0])
    _, s2, *_ = _step(env, params, s, [grid.ACTIONS.index("left"), grid.ACTIONS.index("up")])
    np.testing.assert_array_equal(np.asarray(s2.energy), [15.0, 8.0])


def test_a_disabled_collectors_actions_are_ignored():
    env = DCGTeam(collectors=2, strategies=("patrol",))
    params = env.make_params()
    s = _state(env, params, [(2, 2), (3, 3)], opp=[(4, 0)], items={(2, 3): 1.0}, outcome=[CAUGHT, RUNNING],
               energy=[5.0, 9.0])
    _, s2, reward, _, _, info = _step(env, params, s, [grid.ACTIONS.index("right"), 0])
    assert tuple(np.asarray(s2.pos[0])) == (2, 2) and float(s2.energy[0]) == 5.0
    assert float(reward) == 0.0 and float(s2.items[2, 3]) == 1.0
    avail = np.asarray(env.get_avail_actions(s))
    assert avail.shape == (2, grid.NUM_ACTIONS)
    np.testing.assert_array_equal(avail[0], np.arange(grid.NUM_ACTIONS) == grid.STAY)
    assert avail[1].all()


def test_four_collectors_two_opponents_under_jit_and_vmap():
    env = DCGTeam(collectors=4, opponents=2)
    params = env.make_params()
    b = 8

    @jax.jit
    def run(key):
        k0, k1 = jax.random.split(key)
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k0, b), params)

        def body(carry, key):
            obs, state = carry
            ka, ks = jax.random.split(key)
            a = jax.random.randint(ka, (b, 4), 0, 9)
            obs, state, r, term, trunc, info = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                jax.random.split(ks, b), state, a, params)
            return (obs, state), (r, term | trunc, info["collector_rewards"], env.world_state(
                jax.tree_util.tree_map(lambda x: x[0], state), params))

        return jax.lax.scan(body, (obs, state), jax.random.split(k1, 60))

    (obs, state), (r, done, per, ws) = run(jax.random.PRNGKey(3))
    assert obs.shape == (b,) + env.observation_shape(params)
    assert obs.shape[1:] == (4, 5, 5, 3 + 10)
    assert state.opponent.pos.shape == (b, 2, 2) and state.strategy.shape == (b, 2)
    for x in (obs, r, per, ws):
        assert np.all(np.isfinite(np.asarray(x)))
    np.testing.assert_allclose(np.asarray(per).sum(-1), np.asarray(r))
    assert np.asarray(done).any() and float(np.asarray(r).sum()) > 0
    low, high = env.observation_bounds(params)
    o = np.asarray(obs)
    assert np.all(o >= low) and np.all(o <= high)
    assert ws.shape == (60,) + env.world_state_shape()


def test_extra_opponents_draw_from_folded_keys():
    env = DCGTeam(collectors=2, opponents=3)
    single = DCG()
    params = env.make_params()
    key = jax.random.PRNGKey(11)
    _, s = env.reset(key, params)
    for j in range(3):
        _, one = single.reset(key if j == 0 else jax.random.fold_in(key, j), params)
        np.testing.assert_array_equal(np.asarray(s.opponent.pos[j]), np.asarray(one.opponent.pos))
        np.testing.assert_array_equal(np.asarray(s.opponent.target[j]), np.asarray(one.opponent.target))
        assert int(s.strategy[j]) == int(one.strategy)
    np.testing.assert_array_equal(np.asarray(s.pos), 0)
    np.testing.assert_array_equal(np.asarray(s.energy), 15.0)


def test_info_keys_and_state_type():
    env = DCGTeam(collectors=2)
    params = env.make_params()
    obs, s = env.reset(jax.random.PRNGKey(0), params)
    assert isinstance(s, TeamState) and obs.shape == (2, 5, 5, 13)
    _, _, _, _, _, info = env.step(jax.random.PRNGKey(1), s, jnp.asarray([12, -3]), params)
    for key in ("outcome", "opponent_action", "strategy", "episode_reward", "episode_energy", "episode_steps",
                "invalid_action", "collector_rewards", "collector_outcomes", "final_observation"):
        assert key in info, key
    np.testing.assert_array_equal(np.asarray(info["invalid_action"]), [True, True])
    assert info["collector_rewards"].shape == (2,) and info["collector_outcomes"].shape == (2,)
    assert isinstance(env.view(s, 1), EnvState)
