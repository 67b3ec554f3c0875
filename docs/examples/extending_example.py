"""The worked example of docs/extending.md: a new variant of the grid problems, end to end.

``Pickup`` is a tiny variant of the DCP (thesis section 4.3): one item on a
risky grid, no energy. The agent starts in the base ``(0, 0)``; each step it
moves (the 9 actions of :mod:`jaxdc.core.grid`), collects the item if it
stands on it, and is then disabled with the risk of its cell. The episode
ends when the item is collected, when the agent is disabled, or (truncated)
after ``max_steps`` steps.

The module shows, in this order, the six things a variant brings:

1. the environment on :class:`jaxdc.core.env.Environment`;
2. a risk-map generator (:class:`jaxdc.core.generators.RiskGenerator`);
3. a network and its registry entry (:mod:`jaxdc.nets.registry`);
4. a named training configuration (:class:`jaxdc.training.presets.Preset`);
5. an exact yardstick (value iteration over every state);
6. a claim judged on our numbers (:class:`jaxdc.core.claims.Verdict`).

tests/docs/test_extending.py runs all of it. In a real variant each part
lives in its own module of the package (see docs/extending.md for where).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxdc.core import grid
from jaxdc.core.claims import Verdict, agreement
from jaxdc.core.env import Environment, Transition
from jaxdc.core.generators import MAX_GENERATED_RISK, RiskGenerator
from jaxdc.core.rollout import run_episodes
from jaxdc.core.sampling import uniform_index
from jaxdc.core.scene import Scene
from jaxdc.core.validate import check_float, check_positive_int
from jaxdc.nets import registry
from jaxdc.training import presets
from jaxdc.training.presets import Preset

# -- 1. the environment ----------------------------------------------------------------------------

#: How an episode ends; ``info["outcome"]`` and ``state.outcome`` index this tuple.
OUTCOMES = ("running", "risk", "collected", "truncated")
RUNNING, RISK, COLLECTED, TRUNCATED = range(len(OUTCOMES))


@struct.dataclass
class PickupParams:
    """Numeric settings: every leaf may differ across a ``vmap`` batch."""

    risk: jax.Array  # [N, N] float32, base risk 0
    max_steps: jax.Array  # int32 step cap (truncation)


@struct.dataclass
class PickupState:
    pos: jax.Array  # [2] int32 (row, col)
    items: jax.Array  # [N, N] float32: 1 on the item's cell (the viewer reads items and pos)
    time: jax.Array  # int32 steps taken (run_episodes reads it)
    outcome: jax.Array  # int32 index into OUTCOMES
    ep_reward: jax.Array  # float32 reward collected so far


class Pickup(Environment[PickupState, PickupParams]):
    """One item on an ``N x N`` risky grid: the DCP of section 4.3 without energy and with a single unit."""

    outcomes = OUTCOMES
    state_type = PickupState
    params_type = PickupParams

    def __init__(self, grid_size: int = 3) -> None:
        self.grid_size = grid.check_grid_size(grid_size)  # static configuration: validated here

    def _config(self) -> tuple:
        return (self.grid_size,)  # equal configurations share compiled code

    def make_params(self, risk: Any = "high", max_steps: int = 6) -> PickupParams:
        """Validated params: a Table 4.2 preset or an ``N x N`` risk map, and the step cap."""
        check_positive_int("max_steps", max_steps, high=1 << 20)
        return PickupParams(risk=jnp.asarray(grid.as_risk_map(risk, self.grid_size), jnp.float32),
                            max_steps=jnp.int32(max_steps))

    def observation_shape(self, params: PickupParams | None = None) -> tuple[int, int, int]:
        return (self.grid_size, self.grid_size, 2)

    def observation_bounds(self, params: PickupParams) -> tuple[float, float]:
        return 0.0, 1.0

    def reset_env(self, key: jax.Array, params: PickupParams) -> tuple[jax.Array, PickupState]:
        n = self.grid_size
        flat = 1 + uniform_index(key, (), n * n - 1)  # any cell but the base
        items = jnp.zeros(n * n, jnp.float32).at[flat].set(1.0).reshape(n, n)
        state = PickupState(pos=jnp.zeros(2, jnp.int32), items=items, time=jnp.int32(0),
                            outcome=jnp.int32(RUNNING), ep_reward=jnp.float32(0.0))
        return self.observe(state, params), state

    def step_env(self, key: jax.Array, state: PickupState, action: Any, params: PickupParams) -> Transition:
        action, invalid = grid.clip_action(action)
        pos = grid.move(state.pos, action, self.grid_size)  # 1. move
        reward = state.items[pos[0], pos[1]]  # 2. collect
        collected = reward > 0
        hit = jax.random.uniform(key) < params.risk[pos[0], pos[1]]  # 3. risk
        time = state.time + 1
        outcome = jnp.select([collected, hit, time >= params.max_steps], [COLLECTED, RISK, TRUNCATED],
                             RUNNING).astype(jnp.int32)
        items = state.items.at[pos[0], pos[1]].set(0.0)
        state = state.replace(pos=pos, items=items, time=time, outcome=outcome, ep_reward=state.ep_reward + reward)
        terminated, truncated = (outcome == COLLECTED) | (outcome == RISK), outcome == TRUNCATED
        info = {"outcome": outcome, "episode_reward": state.ep_reward, "invalid_action": invalid}
        return self.observe(state, params), state, reward, terminated, truncated, info

    def observe(self, state: PickupState, params: PickupParams) -> jax.Array:
        """Two planes ``[N, N, 2]``: the item and the agent (a one-hot cell)."""
        n = self.grid_size
        agent = (jnp.arange(n)[:, None] == state.pos[0]) & (jnp.arange(n)[None, :] == state.pos[1])
        return jnp.stack([state.items, agent.astype(jnp.float32)], -1)

    # the hooks of generic code (the gymnasium wrapper, the viewer): outside jit, one unbatched state
    def render_ansi(self, state: PickupState, params: PickupParams) -> str:
        pos, items = tuple(int(p) for p in np.asarray(state.pos)), np.asarray(state.items)
        n = self.grid_size
        rows = [" ".join("A" if (r, c) == pos else "I" if items[r, c] > 0 else "B" if (r, c) == (0, 0) else "."
                         for c in range(n)) for r in range(n)]
        return "\n".join(rows + [f"reward {float(state.ep_reward):g}, step {int(state.time)}"]) + "\n"

    def scene(self, state: PickupState, params: PickupParams) -> Scene:
        return Scene(items=np.asarray(state.items), agent=np.asarray(state.pos), energy=float("inf"),
                     max_energy=float("inf"), reward=float(state.ep_reward), step=int(state.time),
                     outcome=OUTCOMES[int(state.outcome)], risk=np.asarray(params.risk))


# -- 2. a generator --------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Stripes(RiskGenerator):
    """Risky odd rows: every odd row at one risk drawn uniformly from ``[low, high]``, the even rows at 0."""

    low: float = 0.1
    high: float = 0.5
    name = "stripes"

    def __post_init__(self) -> None:  # frozen, hashable and validated: it may be static configuration
        check_float("Stripes.low", self.low, 0.0, MAX_GENERATED_RISK)
        check_float("Stripes.high", self.high, self.low, MAX_GENERATED_RISK)

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        level = self.low + (self.high - self.low) * jax.random.uniform(key)
        odd = (jnp.arange(grid_size) % 2 == 1)[:, None]
        return jnp.where(odd, level, 0.0) * jnp.ones((grid_size, grid_size), jnp.float32)


# -- 3. a network in the registry ------------------------------------------------------------------

class TinyMLP(nn.Module):
    """``(obs [B, N, N, C], heuristics ignored) -> (logits [B, A], value [B])``: one hidden layer."""

    num_actions: int = 9
    uses_heuristics = False  # the Network protocol of jaxdc.agents.common
    has_aux = False
    aux_params = ()

    @nn.compact
    def __call__(self, obs: jax.Array, heuristics: Any = None) -> tuple[jax.Array, jax.Array]:
        x = nn.relu(nn.Dense(32)(jnp.asarray(obs, jnp.float32).reshape(obs.shape[0], -1)))
        return nn.Dense(self.num_actions)(x), nn.Dense(1)(x)[:, 0]


#: The variant's problem name and its networks (a variant adds these lines to jaxdc/nets/registry.py).
PROBLEM = "pickup"
NETS = {"mlp": registry.NetEntry(TinyMLP)}

# -- 4. a named training configuration -------------------------------------------------------------

#: The variant's recipe (a variant adds it to jaxdc/training/presets.py).
PRESETS = {"pickup_mlp": Preset(PROBLEM, "the worked example of docs/extending.md", "mlp", total_steps=50_000,
                                num_envs=16, lr=1e-3)}


def register() -> None:
    """Make the network and the recipe known by name, as the library's own entries are."""
    registry.REGISTRIES[PROBLEM] = NETS
    presets.EVERY.update(PRESETS)


# -- 5. an exact yardstick -------------------------------------------------------------------------

def optimal_value(risk: Any, max_steps: int) -> float:
    """The expected reward of the best policy: value iteration over every (agent, item) pair.

    ``V_h(p, i) = max_a [1 if p' = i else (1 - risk[p']) V_{h-1}(p', i)]`` with ``p' = move(p, a)`` and
    ``V_0 = 0``; the episode starts in the base with the item uniform on the other cells.
    """
    risk = np.asarray(risk, np.float64)
    n = risk.shape[0]
    cells = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)
    nxt = np.clip(cells[:, None, :] + grid.DELTAS_NP[None], 0, n - 1)  # [cells, actions, 2]
    nxt = nxt[..., 0] * n + nxt[..., 1]
    safe = 1.0 - risk.reshape(-1)[nxt]  # [cells, actions]
    caught = nxt[:, :, None] == np.arange(n * n)[None, None, :]  # [cells, actions, items]
    value = np.zeros((n * n, n * n))  # [agent, item]
    for _ in range(max_steps):
        value = np.max(np.where(caught, 1.0, safe[:, :, None] * value[nxt]), axis=1)
    return float(np.mean(value[0, 1:]))


def random_policy(key: jax.Array, obs: jax.Array, state: PickupState) -> jax.Array:
    """A uniformly random action (``run_episodes``' policy signature)."""
    return jax.random.randint(key, (), 0, grid.NUM_ACTIONS)


def mean_reward(env: Pickup, params: PickupParams, policy: Callable, key: jax.Array,
                episodes: int) -> tuple[float, float]:
    """``(mean, standard error)`` of the episode reward of ``policy`` over ``episodes`` episodes."""
    rewards = np.asarray(run_episodes(env, params, policy, key, episodes).ep_reward, np.float64)
    return float(rewards.mean()), float(rewards.std(ddof=1) / np.sqrt(episodes))


# -- 6. a claim ------------------------------------------------------------------------------------

class Measured(NamedTuple):
    """What the claims read: the exact optimum and a policy's mean reward with its standard error."""

    optimum: float
    mean: float
    se: float


class PickupClaim(NamedTuple):
    """A claim as data: where it is made, its text, and a judge of the measurements (``None``: cannot judge)."""

    source: str
    claim: str
    judge: Callable[[Measured], bool | None]


CLAIMS = (
    PickupClaim("extending.md", "No policy beats the exact optimum", lambda m: m.mean <= m.optimum + 2 * m.se),
    PickupClaim("extending.md", "A random walk collects clearly less than the optimum",
                lambda m: m.mean + 2 * m.se < m.optimum),
)


def judge_claims(measured: Measured) -> list[Verdict]:
    """Every claim of :data:`CLAIMS` judged into the :class:`~jaxdc.core.claims.Verdict` all problems share."""
    ours = f"optimum {measured.optimum:.3f}, policy {measured.mean:.3f} +- {measured.se:.3f}"
    return [Verdict(c.source, c.claim, ours, agreement(c.judge(measured))) for c in CLAIMS]
