"""The full-information DCG as finite tables: the opponent as a finite machine and the rules on arrays of cells.

Both exact yardsticks (:mod:`jaxdc.dcg.exact.one_item`, section 5.5.5, and
:mod:`jaxdc.dcg.exact.many_items`, the standard game of 5.5.1) search the game
of section 5.3 with the opponent's strategy and hidden state known. What they
share lives here: the checks of one setting (:func:`check_params`), the reset
distribution of the opponent (:func:`reset_pairs`), the opponent tabulated by
the env's own :meth:`~jaxdc.dcg.env.DCG.opponent_move` and merged into classes
that behave alike (:func:`opponent_machine`, Moore partition refinement, the
observable being the position; :func:`local_machines` per initial class), and
rules (1)-(3) of :meth:`~jaxdc.dcg.env.DCG.step_env` on arrays of cells
(:func:`successors`, :func:`captures`), and a search's plan from its parent links
(:func:`walk_back`). :mod:`jaxdc.dcg.exact.team` uses them for two collectors.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.dcg.opponents import CHASE_TIES, OpponentState

#: The largest grid the exact searches accept: they tabulate the opponent on all ``2 N^6`` (state, collector) pairs.
MAX_GRID_SIZE = 7


# -- validation (outside jit) ----------------------------------------------------------------------


def _scalar(params, name):
    x = np.asarray(getattr(params, name))
    if x.ndim != 0:
        raise ValueError(f"params.{name} must be a scalar (one setting, not a vmapped batch), got shape {x.shape}")
    return x.item()


def check_params(params):
    """``(max_energy, max_steps)`` of one setting, checked for the exact search: whole energy (or inf) and a
    deterministic ``chase_tie``; ``ValueError`` otherwise."""
    energy = float(_scalar(params, "max_energy"))
    if not (math.isinf(energy) or (energy >= 1 and energy == math.floor(energy))):
        raise ValueError(f"max_energy must be a whole number >= 1 or inf for the exact bound, got {energy!r}")
    tie = int(_scalar(params, "chase_tie"))
    if CHASE_TIES[tie] == "random":
        raise ValueError("chase_tie must be deterministic ('straight' or 'order') for the exact bound, got 'random'")
    return energy, int(_scalar(params, "max_steps"))


# -- the opponent as a finite machine --------------------------------------------------------------


def reset_pairs(env) -> np.ndarray:
    """``[C, C]`` probabilities of (start, patrol end) under :meth:`~jaxdc.dcg.env.DCG.reset_env`."""
    c = env.grid_size**2
    starts = np.arange(1, c) if env.opponent_start == "not_base" else np.arange(c)
    w = np.zeros((c, c))
    for h in starts:
        ends = [t for t in range(1, c) if env.patrol_target != "other" or t != h]
        w[h, ends] = 1.0 / (len(starts) * len(ends))
    return w


@jax.jit
def _moves(env_params, strategy, key, pos, home, target, phase, me):
    """``DCG.opponent_move`` for every opponent state (leading axis) x collector cell (second axis)."""
    env, params = env_params.env, env_params.params
    _, template = env.reset_env(jax.random.PRNGKey(0), params)
    template = template.replace(strategy=strategy)

    def one(pos, home, target, phase, me):
        opp = OpponentState(pos=pos, home=home, target=target, phase=phase)
        _, new = env.opponent_move(key, template.replace(pos=me, opponent=opp), params)
        return new.pos, new.home, new.target, new.phase

    inner = jax.vmap(one, in_axes=(None, None, None, None, 0))
    return jax.vmap(inner, in_axes=(0, 0, 0, 0, None))(pos, home, target, phase, me)


@jax.tree_util.register_pytree_node_class
class _EnvAndParams:
    """The env (static) and its params (traced) as one jit argument."""

    def __init__(self, env, params):
        self.env, self.params = env, params

    def tree_flatten(self):
        return (self.params,), self.env

    @classmethod
    def tree_unflatten(cls, env, children):
        return cls(env, children[0])


def _opponent_table(env, params, strategy: int):
    """The env's opponent move over all states ``(pos, home, target, phase in {0,1})`` x collector cells.

    Returns ``next[F, C]`` (full state indices, ``F = 2 C^3``) computed by
    :meth:`~jaxdc.dcg.env.DCG.opponent_move` itself, so the solver and the env cannot drift
    apart. Raises if the strategy changes ``home``/``target``, uses another
    phase, or is random (two keys disagree).
    """
    n, c = env.grid_size, env.grid_size**2
    coords = np.stack(np.divmod(np.arange(c), n), -1).astype(np.int32)
    full = np.arange(2 * c**3)
    pos, home, target, phase = full // (2 * c * c), full // (2 * c) % c, full // 2 % c, full % 2
    args = (coords[pos], coords[home], coords[target], phase.astype(np.int32), coords)
    ep, s = _EnvAndParams(env, params), jnp.int32(strategy)
    out = [np.asarray(x) for x in _moves(ep, s, jax.random.PRNGKey(1), *args)]
    again = [np.asarray(x) for x in _moves(ep, s, jax.random.PRNGKey(2), *args)]
    name = env.strategies[strategy]
    if any(not np.array_equal(a, b) for a, b in zip(out, again)):
        raise ValueError(f"strategy {name!r} is random here (check chase_tie); "
                         "the exact bound needs a deterministic opponent")
    npos, nhome, ntarget, nphase = out
    flat = lambda xy: xy[..., 0] * n + xy[..., 1]  # noqa: E731
    if not (np.array_equal(flat(nhome), np.broadcast_to(home[:, None], nphase.shape))
            and np.array_equal(flat(ntarget), np.broadcast_to(target[:, None], nphase.shape))
            and np.isin(nphase, (0, 1)).all()):
        raise NotImplementedError(f"strategy {name!r} changes home/target or uses a phase outside 0/1; not supported")
    return ((flat(npos) * c + home[:, None]) * c + target[:, None]) * 2 + nphase


def opponent_machine(env, params, strategy: int, weight: np.ndarray):
    """Reachable opponent states merged into classes (Moore refinement).

    Returns ``(cls_next [K, C], cls_pos [K], init_class [C, C])``.
    """
    c = env.grid_size**2
    nxt = _opponent_table(env, params, strategy)
    homes, targets = np.nonzero(weight > 0)
    init_full = ((homes * c + homes) * c + targets) * 2
    seen = np.zeros(nxt.shape[0], bool)
    seen[init_full] = True
    frontier = np.unique(init_full)
    while frontier.size:
        succ = np.unique(nxt[frontier])
        frontier = succ[~seen[succ]]
        seen[frontier] = True
    reach = np.flatnonzero(seen)
    local = np.full(nxt.shape[0], -1)
    local[reach] = np.arange(reach.size)
    t = local[nxt[reach]]  # [R, C]
    cls = np.unique(reach // (2 * c * c), return_inverse=True)[1].reshape(-1)
    while True:
        sig = np.column_stack([cls, cls[t]])
        _, new = np.unique(sig, axis=0, return_inverse=True)
        new = new.reshape(-1)
        if new.max() == cls.max():
            break
        cls = new
    k = int(cls.max()) + 1
    rep = np.zeros(k, np.int64)
    rep[cls] = np.arange(reach.size)
    init = np.full((c, c), -1, np.int64)
    init[homes, targets] = cls[local[init_full]]
    return cls[t[rep]], reach[rep] // (2 * c * c), init


# -- the rules on arrays of cells --------------------------------------------------------------


def captures(env, p, q2, p2):
    """Rules (1) and (3) of :meth:`~jaxdc.dcg.env.DCG.step_env` on arrays of cells, for the env's rule readings.

    ``p`` [F] the collector's cells, ``q2`` [F] the opponent's after it moved, ``p2`` [F, A] the collector's
    after each action. Returns ``free`` [F] (not caught before moving) and ``met`` [F, A] (caught after).
    """
    free = q2 != p
    met = p2 == q2[:, None]
    if env.safe_base:
        free = free | (p == 0)
        met = met & (p2 != 0)
    if env.capture == "opponent_moves":
        met = np.zeros_like(met)
    return free, met


def successors(n: int) -> np.ndarray:
    """``[N*N, 9]``: the flat cell each of the 9 actions leads to from each flat cell (moves clipped per axis)."""
    r, cc = np.divmod(np.arange(n * n), n)
    rr = np.clip(r[:, None] + grid.DELTAS_NP[None, :, 0], 0, n - 1)
    cl = np.clip(cc[:, None] + grid.DELTAS_NP[None, :, 1], 0, n - 1)
    return rr * n + cl


def local_machines(cls_next, cls_pos, init_b):
    """Per initial class ``b``, the classes reachable from it, relabelled ``0 .. L-1`` (padded).

    Returns ``(next [B, L, C], pos [B, L])``; padding rows point to themselves.
    """
    nb = init_b.size
    k = cls_next.shape[0]
    reach = np.zeros((nb, k), bool)
    reach[np.arange(nb), init_b] = True
    fb, fk = np.arange(nb), init_b
    while fb.size:
        pair = np.unique(fb[:, None] * k + cls_next[fk], axis=None)
        pb, pk = np.divmod(pair, k)
        new = ~reach[pb, pk]
        fb, fk = pb[new], pk[new]
        reach[fb, fk] = True
    size = reach.sum(axis=1)
    width = int(size.max())
    # the initial class first, then the others in index order
    order = np.argsort(~reach + 2 * (np.arange(k)[None, :] != init_b[:, None]), axis=1, kind="stable")[:, :width]
    glob = order  # [B, L] global class of each local index
    valid = np.arange(width)[None, :] < size[:, None]
    local = np.zeros((nb, k), np.int64)
    local[np.arange(nb)[:, None], glob] = np.arange(width)[None, :]
    nxt = local[np.arange(nb)[:, None, None], cls_next[glob]]  # [B, L, C]
    nxt = np.where(valid[..., None], nxt, np.arange(width)[None, :, None])
    return nxt, cls_pos[glob]



def walk_back(parent: np.ndarray, action: np.ndarray, src: int, last: int) -> np.ndarray:
    """The action plan of a search: the actions along ``parent`` links from the reset state (parent ``-1``) to
    state ``src``, then ``last`` (its best transition); empty when ``src < 0`` (nothing was collected)."""
    plan = []
    if src >= 0:
        plan.append(last)
        node = src
        while parent[node] >= 0:
            plan.append(int(action[node]))
            node = parent[node]
    return np.array(plan[::-1], np.int8)
