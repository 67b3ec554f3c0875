"""Hand-made states and risk maps shared by the DCP, DCG and viewer tests."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from jaxdc.dcp.env import RUNNING, EnvState


def items_grid(n, items):
    """``items``: a dict ``{(row, col): reward}`` or an ``[N, N]`` array."""
    if isinstance(items, dict):
        arr = np.zeros((n, n), np.float32)
        for (r, c), v in items.items():
            arr[r, c] = v
        return arr
    return np.asarray(items, np.float32)


def make_state(env, pos, energy, items, rank=None, time=0, ep_reward=0.0, ep_energy=0):
    """A hand-made :class:`EnvState` of ``env`` (rank: dict {(r, c): rank} or array; default row-major)."""
    n = env.grid_size
    if rank is None:
        rank_arr = np.arange(n * n, dtype=np.int32).reshape(n, n)
    elif isinstance(rank, dict):
        rank_arr = np.full((n, n), 10_000, np.int32)
        for (r, c), v in rank.items():
            rank_arr[r, c] = v
    else:
        rank_arr = np.asarray(rank, np.int32)
    return EnvState(
        pos=jnp.asarray(pos, jnp.int32),
        energy=jnp.float32(energy),
        items=jnp.asarray(items_grid(n, items)),
        time=jnp.int32(time),
        outcome=jnp.int32(RUNNING),
        ep_reward=jnp.float32(ep_reward),
        ep_energy=jnp.int32(ep_energy),
        rank=jnp.asarray(rank_arr),
    )


def risk_with(n, cells=None, fill=0.0):
    """An ``N x N`` risk map of ``fill`` (base 0) with ``cells = {(r, c): risk}`` set."""
    risk = np.full((n, n), fill, np.float32)
    risk[0, 0] = 0.0
    for (r, c), v in (cells or {}).items():
        risk[r, c] = v
    return risk


def make_game(env, pos, opp, strategy, items=None, energy=15.0, home=None, target=None, phase=0):
    """A hand-made DCG state (collector at ``pos``, opponent at ``opp``); shared by the DCG tests."""
    from jaxdc.dcg import EnvState, OpponentState

    n = env.grid_size
    arr = np.zeros((n, n), np.float32)
    for (r, c), v in (items or {}).items():
        arr[r, c] = v
    home = opp if home is None else home
    return EnvState(
        pos=jnp.asarray(pos, jnp.int32), energy=jnp.float32(energy), items=jnp.asarray(arr),
        opponent=OpponentState(pos=jnp.asarray(opp, jnp.int32), home=jnp.asarray(home, jnp.int32),
                               target=jnp.asarray(home if target is None else target, jnp.int32),
                               phase=jnp.int32(phase)),
        strategy=jnp.int32(env.strategies.index(strategy)), history=jnp.zeros((n, n, env.history), jnp.float32),
        time=jnp.int32(0), outcome=jnp.int32(0), ep_reward=jnp.float32(0), ep_energy=jnp.int32(0),
    )
