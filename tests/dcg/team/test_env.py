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
