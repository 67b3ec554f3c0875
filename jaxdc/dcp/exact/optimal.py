"""The exact optimum of the single-item DCP (Table 4.8, section 4.5.4).

Section 4.5.4 runs the DCP of section 4.3 with one item of reward one. With a
single item the MDP is small enough to solve exactly: a state with the item
still present is ``(agent cell, energy e in 1..E, item cell)``; the agent
being disabled, or the item being collected, ends the episode. The total
expected reward of an episode is therefore the probability of collecting the
item, and :func:`solve_single_item` computes its maximum by value iteration
(float64, numpy; one vectorised Bellman backup per iteration).

The transition is exactly the one of :meth:`jaxdc.dcp.env.DCP.step_env`
(section 4.3, "The transition from s_t to s_{t+1}"):

1. the agent moves to ``p' = move(p, a)`` (clipped per axis);
2. if the item is in ``p'`` it is collected: reward 1, the episode ends
   (the item is collected *before* the risk draw, so a reward is never lost);
3. otherwise the agent survives with probability ``1 - rho[p']``;
4. its energy becomes the maximum ``E`` if ``p'`` is the base, else ``e - 1``,
   and it is disabled when that is 0 outside the base.

Staying in the base forever earns 0, so with ``gamma = 1`` the optimum is
well defined; value iteration from 0 increases monotonically to it.

:func:`expected_optimum` averages the optimal values over the initial
distribution of :meth:`jaxdc.dcp.env.DCP.reset_env` and :func:`optimal_policy`
turns the greedy table into a ``policy(key, obs, state)`` for
:func:`jaxdc.core.rollout.run_episodes`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.core.validate import check_choice
from jaxdc.dcp.env import STARTS


class OptimalSolution(NamedTuple):
    """The solved single-item DCP (Table 4.8 setting, section 4.5.4).

    ``values[p, e, i]``: the maximal probability of collecting the item in
    cell ``i`` (row-major flat index) from agent cell ``p`` with energy ``e``
    (``e = 0``: disabled, value 0). ``values[0, e < E, i]`` is the base with
    less than full energy, which only occurs at reset (``energy =
    init_energy`` wherever the agent starts). ``values[i, e, i]`` is an agent
    standing on the item at reset (``start="random"``): ``stay`` collects it, so 1.

    ``policy[p, e, i]``: a greedy optimal action (int32, ties -> lowest
    action index; in the base with full energy the actions that leave the
    state unchanged are never chosen, so the greedy policy always makes
    progress). ``policy[:, 0, :]`` is 0 (unused).
    """

    values: np.ndarray  # [N*N, E+1, N*N] float64
    policy: np.ndarray  # [N*N, E+1, N*N] int32
    risk: np.ndarray  # [N, N] float64
    max_energy: int
    init_energy: int
    gamma: float
    iterations: int
    residual: float  # max |V_{k+1} - V_k| of the last iteration

    @property
    def grid_size(self) -> int:
        return int(self.risk.shape[0])


def _check_int_energy(name: str, e) -> int:
    if isinstance(e, bool):
        raise ValueError(f"{name} must be a finite integer >= 1, got {e!r}")
    try:
        f = float(e)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite integer >= 1, got {e!r}") from None
    if not math.isfinite(f) or f != math.floor(f) or f < 1:
        raise ValueError(f"{name} must be a finite integer >= 1 (the exact solver needs integer energy), got {e!r}")
    return int(f)


def _successors(n: int) -> np.ndarray:
    """``[N*N, 9]`` flat cell reached by each action (``grid.move``, clipped per axis)."""
    r, c = np.divmod(np.arange(n * n), n)
    rr = np.clip(r[:, None] + grid.DELTAS_NP[None, :, 0], 0, n - 1)
    cc = np.clip(c[:, None] + grid.DELTAS_NP[None, :, 1], 0, n - 1)
    return (rr * n + cc).astype(np.int64)


def _q_values(v: np.ndarray, succ: np.ndarray, rho: np.ndarray, gamma: float) -> np.ndarray:
    """``Q[p, e, i, a]`` for energies ``e = 1..E`` (index ``e - 1``) from values ``v[p, e, i]``."""
    cells, e1, _ = v.shape
    big_e = e1 - 1
    # w[p', e, i]: continuation value after arriving (item not there, survived) with pre-step energy e
    w = np.empty((cells, big_e, cells))
    w[:] = v[:, :big_e, :]  # outside the base: energy e - 1 (index e - 1; 0 = disabled -> 0)
    w[0] = v[0, big_e, :][None, :]  # base: refill to E
    surv = (1.0 - rho.reshape(-1))[:, None, None] * w  # [p', e, i]
    item = np.arange(cells)
    q = np.empty((cells, big_e, cells, succ.shape[1]))
    for a in range(succ.shape[1]):
        nxt = succ[:, a]
        qa = gamma * surv[nxt]  # [p, e, i]
        hit = nxt[:, None] == item[None, :]  # [p, i]: the item is collected
        qa[np.broadcast_to(hit[:, None, :], qa.shape)] = 1.0
        q[..., a] = qa
    return q


#: Bytes per (cell, energy, item cell) state the solver holds at once: the Q values of the 9 actions and
#: about six value-sized float64 arrays (values, the update, the continuation, its survival-weighted copy).
SOLVER_BYTES_PER_STATE = 8 * (9 + 6)


def check_solver_fits(grid_size: int, max_energy: int) -> None:
    """``MemoryError`` (what to lower) if the solver's arrays for this grid and energy cannot be held."""
    from jaxdc.core import memory

    cells = grid_size * grid_size
    memory.check_fits(SOLVER_BYTES_PER_STATE * cells * cells * (max_energy + 1),
                      f"the exact single-item solver on a {grid_size}x{grid_size} grid with maximum energy "
                      f"{max_energy}", "the grid size or the maximum energy")


def solve_single_item(
    risk,
    max_energy,
    init_energy,
    gamma: float = 1.0,
    tol: float = 1e-7,
    max_iter: int = 100_000,
    grid_size: int = 8,
) -> OptimalSolution:
    """Exact optimal values and a greedy policy of the single-item DCP (Table 4.8).

    Value iteration (float64) on the states of section 4.3 with the item
    still present; reward 1 on collecting the item, 0 otherwise; disabled is
    absorbing with value 0. Iterates until the largest change of a value is
    below ``tol`` (values are probabilities, so the stopping error is about
    ``tol`` times the number of remaining base visits, negligible here).

    Args:
      risk: a preset of Table 4.2 (``"low"``, ``"medium"``, ``"high"``, 8x8) or
        an ``N x N`` risk map (base risk 0).
      max_energy, init_energy: finite integers ``1 <= init_energy <= max_energy``.
      gamma: discount in ``(0, 1]``; the thesis' objective is ``gamma = 1``.
      tol: stopping threshold on the max change per iteration.
      max_iter: raises ``RuntimeError`` if not converged by then.
      grid_size: the grid size of a preset ``risk`` (ignored for an array).

    A grid and energy whose arrays the machine cannot hold raise ``MemoryError``
    before any is allocated (:func:`check_solver_fits`).
    """
    size = grid_size if isinstance(risk, str) else np.shape(risk)[0]
    rho = np.asarray(grid.as_risk_map(risk, size), np.float64)
    big_e = _check_int_energy("max_energy", max_energy)
    e0 = _check_int_energy("init_energy", init_energy)
    if e0 > big_e:
        raise ValueError(f"init_energy ({e0}) must not exceed max_energy ({big_e})")
    gamma = float(gamma)
    if not (0.0 < gamma <= 1.0):
        raise ValueError(f"gamma must lie in (0, 1], got {gamma}")
    if not (tol > 0):
        raise ValueError(f"tol must be > 0, got {tol}")
    n = rho.shape[0]
    cells = n * n
    check_solver_fits(n, big_e)
    succ = _successors(n)
    v = np.zeros((cells, big_e + 1, cells))
    residual = math.inf
    it = 0
    while it < max_iter:
        it += 1
        new = np.zeros_like(v)
        new[:, 1:, :] = _q_values(v, succ, rho, gamma).max(axis=-1)
        residual = float(np.abs(new - v).max())
        v = new
        if residual < tol:
            break
    else:
        raise RuntimeError(f"value iteration did not converge in {max_iter} iterations (residual {residual:.3g})")
    q = _q_values(v, succ, rho, gamma)
    # In the base with full energy, actions that stay in the base leave the state unchanged: their
    # Q equals the optimum (a tie that would loop forever), so exclude them from the greedy choice.
    self_loop = succ[0] == 0
    q[0, big_e - 1][:, self_loop] = -np.inf
    policy = np.zeros((cells, big_e + 1, cells), np.int32)
    policy[:, 1:, :] = np.argmax(q, axis=-1)
    return OptimalSolution(
        values=v, policy=policy, risk=rho, max_energy=big_e, init_energy=e0,
        gamma=gamma, iterations=it, residual=residual,
    )


def expected_optimum(sol: OptimalSolution, items_on_base: bool = True, start: str = "random_free") -> float:
    """Optimal expected episode reward under the initial distribution of ``DCP.reset_env``.

    The item is uniform over all ``N*N`` cells (over the ``N*N - 1`` non-base
    cells when ``items_on_base=False``); the agent starts uniformly on an
    item-free cell (``"random_free"``), on any cell (``"random"``) or in the
    base (``"base"``), always with ``energy = init_energy`` (also in the base),
    as in ``reset_env``. This is the best achievable "Reward Avg." of Table 4.8.
    """
    check_choice("start", start, STARTS)
    cells = sol.values.shape[0]
    v = sol.values[:, sol.init_energy, :]  # [agent, item]
    items = np.arange(0 if items_on_base else 1, cells)
    if start == "base":
        per_item = v[0, items]
    elif start == "random":
        per_item = v[:, items].mean(axis=0)
    else:
        per_item = (v[:, items].sum(axis=0) - v[items, items]) / (cells - 1)
    return float(per_item.mean())


def optimal_policy(sol: OptimalSolution):
    """``policy(key, obs, state) -> action`` of the greedy optimal table, for ``run_episodes``.

    Use with ``DCP(grid_size=N, total_reward=1)`` and parameters with the same
    risk map and integer energies: it looks up ``sol.policy[agent, energy,
    item]`` with the item cell ``argmax(state.items)`` (section 4.5.4: one item).
    """
    table = jnp.asarray(sol.policy)
    n = sol.grid_size
    big_e = sol.max_energy

    def policy(key, obs, state):
        agent = state.pos[0] * n + state.pos[1]
        energy = jnp.clip(jnp.round(state.energy), 0, big_e).astype(jnp.int32)
        item = jnp.argmax(state.items.reshape(-1))
        return table[agent, energy, item]

    return policy
