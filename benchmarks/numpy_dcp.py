"""A plain NumPy, single-environment DCP (section 4.3): the throughput baseline.

It implements the same rules as :class:`jaxdc.dcp.env.DCP` (see that module's
docstring), one environment at a time with Python control flow, the way a
straightforward gym-style implementation would:

* reset: ``total_reward`` unit rewards dropped multinomially (uniform cell per
  unit, optionally never on the base), then the start cell (``random_free``:
  a uniformly random cell without an item, any cell if none is free;
  ``random``; ``base``), energy = initial energy;
* step: move (clipped per axis), collect the item of the new cell, disabled
  with that cell's risk, energy refills in the base / else drops by one and
  disables at 0; terminate on risk, energy, all items collected, optionally
  idle (state unchanged); truncate at ``max_steps``;
* :meth:`NumpyDCP.step` auto-resets like :meth:`jaxdc.core.env.Environment.step`.

Random numbers come from a ``numpy.random.Generator``, so the streams differ
from JAX's; only the rules (and hence the distributions) are shared.
"""

from __future__ import annotations

import numpy as np

from jaxdc.core import grid
from jaxdc.dcp.env import CLEARED, ENERGY, IDLE, RISK, RUNNING, TRUNCATED

DELTAS = grid.DELTAS_NP


class NumpyDCP:
    """One DCP environment in NumPy (start ``random_free``, energy metric ``not_stay_in_base``)."""

    def __init__(self, risk="high", energy=(8.0, 16.0), max_steps: int = 200, grid_size: int = 8,
                 total_reward: int = 30, items_on_base: bool = True, idle_terminates: bool = False,
                 start: str = "random_free"):
        if start not in ("random_free", "random", "base"):
            raise ValueError(f"unknown start {start!r}")
        self.n = int(grid_size)
        self.risk = np.asarray(grid.as_risk_map(risk, self.n), np.float64)
        self.init_energy, self.max_energy = (float(e) for e in energy)
        self.max_steps = int(max_steps)
        self.total_reward = int(total_reward)
        self.items_on_base = bool(items_on_base)
        self.idle_terminates = bool(idle_terminates)
        self.start = start
        # state
        self.pos = np.zeros(2, np.int64)
        self.energy = self.init_energy
        self.items = np.zeros((self.n, self.n))
        self.time = 0
        self.outcome = RUNNING
        self.ep_reward = 0.0
        self.ep_energy = 0

    # -- dynamics ------------------------------------------------------------------------
    def reset(self, rng: np.random.Generator) -> np.ndarray:
        n = self.n
        low = 0 if self.items_on_base else 1
        cells = rng.integers(low, n * n, size=self.total_reward)
        self.items = np.bincount(cells, minlength=n * n).astype(np.float64).reshape(n, n)
        if self.start == "base":
            flat = 0
        elif self.start == "random":
            flat = int(rng.integers(n * n))
        else:
            free = np.flatnonzero(self.items.reshape(-1) == 0)
            flat = int(rng.choice(free)) if free.size else int(rng.integers(n * n))
        self.pos = np.array(divmod(flat, n), np.int64)
        self.energy = self.init_energy
        self.time = 0
        self.outcome = RUNNING
        self.ep_reward = 0.0
        self.ep_energy = 0
        return self.observe()

    def step_env(self, rng: np.random.Generator, action: int):
        """One transition without auto-reset: ``(obs, reward, terminated, truncated)``."""
        n = self.n
        old_pos, old_energy = self.pos, self.energy
        pos = np.clip(old_pos + DELTAS[action], 0, n - 1)
        r, c = int(pos[0]), int(pos[1])
        reward = float(self.items[r, c])
        self.items[r, c] = 0.0
        hit = rng.random() < self.risk[r, c]
        in_base = r == 0 and c == 0
        was_in_base = old_pos[0] == 0 and old_pos[1] == 0
        energy = self.max_energy if in_base else old_energy - 1.0
        out_of_energy = (not in_base) and energy <= 0
        cleared = not (self.items > 0).any()
        unchanged = (r == old_pos[0] and c == old_pos[1] and energy == old_energy and reward == 0
                     and not hit and not out_of_energy)
        self.time += 1
        if hit:
            outcome = RISK
        elif out_of_energy:
            outcome = ENERGY
        elif cleared:
            outcome = CLEARED
        elif self.idle_terminates and unchanged:
            outcome = IDLE
        elif self.time >= self.max_steps:
            outcome = TRUNCATED
        else:
            outcome = RUNNING
        self.pos, self.energy, self.outcome = pos, energy, outcome
        self.ep_reward += reward
        self.ep_energy += int(not (in_base and was_in_base))
        terminated = outcome not in (RUNNING, TRUNCATED)
        return self.observe(), reward, terminated, outcome == TRUNCATED

    def step(self, rng: np.random.Generator, action: int):
        """``step_env`` with auto-reset: ``(obs, reward, terminated, truncated, final_obs)``."""
        obs, reward, terminated, truncated = self.step_env(rng, action)
        final = obs
        if terminated or truncated:
            obs = self.reset(rng)
        return obs, reward, terminated, truncated, final

    def observe(self) -> np.ndarray:
        """``[N, N, 2]``: item rewards and the energy at the agent's cell."""
        obs = np.zeros((self.n, self.n, 2), np.float32)
        obs[..., 0] = self.items
        obs[self.pos[0], self.pos[1], 1] = self.energy
        return obs


def random_rollout(env: NumpyDCP, rng: np.random.Generator, steps: int) -> float:
    """``steps`` auto-reset steps with a uniformly random policy; returns the total reward."""
    env.reset(rng)
    total = 0.0
    for a in rng.integers(0, grid.NUM_ACTIONS, size=steps):
        total += env.step(rng, int(a))[1]
    return total


def plain_loop(rng: np.random.Generator, steps: int, risk="high", energy=(8.0, 16.0), max_steps: int = 200,
               grid_size: int = 8, total_reward: int = 30) -> float:
    """``steps`` auto-reset random-policy steps of one DCP, written as a plain NumPy user would (the
    ``numpy_loop`` row): Python ints for the position, one flat item array, the observation updated in
    place, random numbers drawn in blocks. The rules are :class:`NumpyDCP`'s; returns the total reward."""
    n = int(grid_size)
    cells = n * n
    risk_flat = np.asarray(grid.as_risk_map(risk, n), np.float64).reshape(-1).tolist()
    init_e, max_e = (float(e) for e in energy)
    deltas = [(int(dr), int(dc)) for dr, dc in DELTAS]
    obs = np.zeros((n, n, 2), np.float32)
    items_view = obs[..., 0].reshape(-1)  # the item plane is the state
    agent_view = obs[..., 1]
    actions = rng.integers(0, grid.NUM_ACTIONS, size=steps).tolist()
    coins = rng.random(steps).tolist()

    def reset():
        items_view[:] = np.bincount(rng.integers(0, cells, size=total_reward), minlength=cells)
        free = np.flatnonzero(items_view == 0)
        flat = int(rng.choice(free)) if free.size else int(rng.integers(cells))
        return flat // n, flat % n, init_e, 0, int(np.count_nonzero(items_view))

    r, c, e, t, left = reset()
    total = 0.0
    for a, u in zip(actions, coins):
        agent_view[r, c] = 0.0
        dr, dc = deltas[a]
        r, c = min(max(r + dr, 0), n - 1), min(max(c + dc, 0), n - 1)
        flat = r * n + c
        reward = float(items_view[flat])
        if reward:
            items_view[flat] = 0.0
            left -= 1
            total += reward
        in_base = flat == 0
        e = max_e if in_base else max(e - 1.0, 0.0)
        t += 1
        if u < risk_flat[flat] or (not in_base and e <= 0) or left == 0 or t >= max_steps:
            r, c, e, t, left = reset()
        agent_view[r, c] = e
    return total


class BatchedNumpyDCP:
    """``batch`` DCPs stepped at once in NumPy (the ``numpy_batched`` row): :class:`NumpyDCP`'s rules over
    arrays whose leading axis is the batch; only the environments that finished are reset."""

    def __init__(self, batch: int, risk="high", energy=(8.0, 16.0), max_steps: int = 200, grid_size: int = 8,
                 total_reward: int = 30):
        self.b, self.n = int(batch), int(grid_size)
        self.cells = self.n * self.n
        self.risk = np.asarray(grid.as_risk_map(risk, self.n), np.float64).reshape(-1)
        self.init_energy, self.max_energy = (float(e) for e in energy)
        self.max_steps, self.total_reward = int(max_steps), int(total_reward)
        self.items = np.zeros((self.b, self.cells))
        self.flat = np.zeros(self.b, np.int64)
        self.energy = np.zeros(self.b)
        self.time = np.zeros(self.b, np.int64)

    def reset(self, rng: np.random.Generator, idx: np.ndarray) -> None:
        """Fresh initial states for the environments ``idx``."""
        k = idx.size
        if k == 0:
            return
        where = rng.integers(0, self.cells, size=(k, self.total_reward)) + self.cells * np.arange(k)[:, None]
        items = np.bincount(where.reshape(-1), minlength=k * self.cells).reshape(k, self.cells).astype(np.float64)
        free = items == 0
        free[~free.any(1)] = True
        count = np.cumsum(free, axis=1)
        pick = (rng.random(k) * count[:, -1]).astype(np.int64)
        self.items[idx] = items
        self.flat[idx] = (count <= pick[:, None]).sum(1)
        self.energy[idx] = self.init_energy
        self.time[idx] = 0

    def step(self, rng: np.random.Generator, action: np.ndarray):
        """One auto-reset step of every environment: ``(obs, reward, done)``."""
        n, rows = self.n, np.arange(self.b)
        d = DELTAS[action]
        r = np.clip(self.flat // n + d[:, 0], 0, n - 1)
        c = np.clip(self.flat % n + d[:, 1], 0, n - 1)
        self.flat = r * n + c
        reward = self.items[rows, self.flat].copy()
        self.items[rows, self.flat] = 0.0
        hit = rng.random(self.b) < self.risk[self.flat]
        in_base = self.flat == 0
        self.energy = np.where(in_base, self.max_energy, np.maximum(self.energy - 1.0, 0.0))
        self.time += 1
        done = hit | (~in_base & (self.energy <= 0)) | ~(self.items > 0).any(1) | (self.time >= self.max_steps)
        self.reset(rng, np.flatnonzero(done))
        obs = np.zeros((self.b, self.cells, 2), np.float32)
        obs[..., 0] = self.items
        obs[rows, self.flat, 1] = self.energy
        return obs.reshape(self.b, n, n, 2), reward, done


def batched_rollout(env: BatchedNumpyDCP, rng: np.random.Generator, steps: int) -> float:
    """``steps`` random-policy steps of every environment of ``env``; returns the total reward."""
    env.reset(rng, np.arange(env.b))
    total = 0.0
    for _ in range(steps):
        total += float(env.step(rng, rng.integers(0, grid.NUM_ACTIONS, size=env.b))[1].sum())
    return total
