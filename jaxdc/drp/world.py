"""DRP graph instances, the generator, JSON I/O and the objective (thesis section 3.3).

A world ``G = (V, D, alpha, beta, psi)`` is held as plain arrays:

* ``D``: ``[n+1, n+1]`` Euclidean distances, node 0 is the base;
* ``beta``: ``[n+1]`` node rewards with the convention ``beta[0] = alpha``
  (the value of a robot that returns, section 3.3);
* ``psi``: survival probability per unit distance; ``alpha``: robot value.

A *tour* is an ``int32`` vector of node indices (1..n) in visiting order,
padded with ``-1``; it starts at and returns to the base implicitly.
A *plan* is a ``[T, L]`` stack of tours (rows of ``-1`` are unused robots).

Everything that takes arrays here is a pure function usable under
``jit``/``vmap``; validation and file I/O are plain Python.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

#: The thesis' reward distributions (section 3.5): integer-uniform 4..6, 1..9, all 5.
REWARD_SETTINGS = {"4-6": (4, 6), "1-9": (1, 9), "5": (5, 5)}
#: Base locations considered for the generator (ambiguity: the thesis does not say).
BASE_LOCATIONS = ("corner", "centre")


class Graph(NamedTuple):
    """One DRP instance: base and node coordinates, rewards, psi and alpha."""

    base: np.ndarray  # [2]
    nodes: np.ndarray  # [n, 2]
    rewards: np.ndarray  # [n]
    psi: float
    alpha: float


def distances(base, nodes):
    """Euclidean distance matrix ``D`` with the base as node 0 (triangle inequality holds)."""
    pts = jnp.concatenate([jnp.asarray(base, jnp.float32)[None, :], jnp.asarray(nodes, jnp.float32)])
    diff = pts[:, None, :] - pts[None, :, :]
    return jnp.sqrt(jnp.sum(diff * diff, axis=-1))


def node_values(rewards, alpha):
    """``beta`` with ``beta[0] = alpha`` (section 3.3)."""
    return jnp.concatenate([jnp.asarray([alpha], jnp.float32), jnp.asarray(rewards, jnp.float32)])


def arrays(graph: Graph):
    """``(D, beta, psi)`` of a :class:`Graph`, the inputs of every planner."""
    return distances(graph.base, graph.nodes), node_values(graph.rewards, graph.alpha), jnp.float32(graph.psi)


def tour_parts(dist, beta_of, psi, tour, xp=jnp):
    """The two alpha-free parts of Eq. 3.1 for tours ``[..., L]``: ``(sum_v P_t(v) beta(v), P_t(0))``.

    ``dist(a, b)`` and ``beta_of(v)`` look up distances and node rewards for index
    arrays shaped like ``tour`` (or like ``tour[..., 0]``), so one code serves a
    single graph under ``jit`` (``xp = jax.numpy``) and a batch of tours of many
    graphs on the host (``xp = numpy``, float64: :mod:`jaxdc.drp.evaluate`).
    ``psi`` is a scalar or has the batch shape ``tour.shape[:-1]``. An empty tour
    (all ``-1``) has parts ``(0, 0)``.
    """
    valid = tour >= 0
    node = xp.where(valid, tour, 0)
    prev = xp.concatenate([xp.zeros_like(node[..., :1]), node[..., :-1]], axis=-1)
    reach = xp.cumsum(xp.where(valid, dist(prev, node), 0.0), axis=-1)  # D_t(0, v)
    psi = xp.asarray(psi)
    collected = xp.sum(xp.where(valid, psi[..., None] ** reach * beta_of(node), 0.0), axis=-1)
    count = valid.sum(-1)
    last = xp.take_along_axis(node, xp.maximum(count - 1, 0)[..., None], axis=-1)[..., 0]
    home = reach[..., -1] + dist(last, xp.zeros_like(last))
    return collected, xp.where(count > 0, psi ** home, 0.0)


def tour_gain(D, beta, psi, tour):
    """The gain of one tour, the inner sum of Eq. 3.1: ``sum_{v in t} P_t(v) beta(v)``.

    The sum runs over the visited nodes *and* the final return to 0, whose
    value is ``beta[0] = alpha``. An empty tour (all ``-1``) has gain 0.
    """
    collected, p_return = tour_parts(lambda a, b: D[a, b], lambda v: beta[v], psi, jnp.asarray(tour))
    return collected + p_return * beta[0]


def tour_reward(D, beta, psi, tour):
    """Reward of one tour (Eq. 3.1): its gain minus ``alpha``; 0 for an empty tour."""
    nonempty = (jnp.asarray(tour) >= 0).any()
    return jnp.where(nonempty, tour_gain(D, beta, psi, tour) - beta[0], 0.0)


def expected_reward(D, beta, psi, plan):
    """Eq. 3.1: ``sum_t sum_{v in t} P_t(v) beta(v) - |T| alpha`` for a ``[T, L]`` plan."""
    plan = jnp.atleast_2d(jnp.asarray(plan))
    return jax.vmap(lambda t: tour_reward(D, beta, psi, t))(plan).sum()


# ----------------------------------------------------------------------------- generator


def generate(seed: int, n: int = 100, rewards: str = "4-6", base: str = "centre", psi: float = 0.99,
             alpha: float = 20.0, size: float = 100.0) -> Graph:
    """The thesis' set-up (section 3.5): ``n`` nodes uniform in a ``size x size`` square.

    ``rewards`` is one of :data:`REWARD_SETTINGS`; ``base`` is ``corner`` (0, 0)
    or ``centre`` (size/2, size/2). Deterministic in ``seed``.
    """
    if rewards not in REWARD_SETTINGS:
        raise ValueError(f"rewards must be one of {sorted(REWARD_SETTINGS)}, got {rewards!r}")
    if base not in BASE_LOCATIONS:
        raise ValueError(f"base must be one of {BASE_LOCATIONS}, got {base!r}")
    if not (isinstance(n, numbers.Integral) and n >= 1):
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    rng = np.random.default_rng(seed)
    nodes = rng.uniform(0.0, size, size=(n, 2))
    lo, hi = REWARD_SETTINGS[rewards]
    beta = rng.integers(lo, hi + 1, size=n).astype(np.float64)
    b = np.zeros(2) if base == "corner" else np.full(2, size / 2)
    return validate(Graph(b, nodes, beta, psi, alpha))


# ----------------------------------------------------------------------------- validation and JSON

_KEYS = ("base", "nodes", "rewards", "psi", "alpha")


def _number(name, value):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(float(value)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)


def _point(name, value):
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2:
        raise ValueError(f"{name} must be a pair [x, y], got {value!r}")
    return [_number(f"{name}[{i}]", v) for i, v in enumerate(value)]


def validate(graph: Graph) -> Graph:
    """Check a graph and return it with numpy arrays; ``ValueError``/``TypeError`` name the field."""
    base_in = graph.base.tolist() if isinstance(graph.base, np.ndarray) else graph.base
    base = np.asarray(_point("base", base_in))
    nodes_in = graph.nodes.tolist() if isinstance(graph.nodes, np.ndarray) else graph.nodes
    if not isinstance(nodes_in, (list, tuple)):
        raise TypeError(f"nodes must be a list of [x, y] pairs, got {type(nodes_in).__name__}")
    if len(nodes_in) == 0:
        raise ValueError("nodes must be a non-empty list of [x, y] pairs, got an empty list")
    nodes = np.asarray([_point(f"nodes[{i}]", p) for i, p in enumerate(nodes_in)])
    rewards_in = graph.rewards.tolist() if isinstance(graph.rewards, np.ndarray) else graph.rewards
    if not isinstance(rewards_in, (list, tuple)):
        raise TypeError(f"rewards must be a list of numbers, got {type(rewards_in).__name__}")
    if len(rewards_in) != len(nodes):
        raise ValueError(f"rewards must have one entry per node: len(rewards)={len(rewards_in)}, "
                         f"len(nodes)={len(nodes)}")
    rewards = np.asarray([_number(f"rewards[{i}]", r) for i, r in enumerate(rewards_in)])
    bad = np.flatnonzero(rewards < 0)
    if bad.size:
        raise ValueError(f"rewards[{bad[0]}] must be >= 0, got {rewards[bad[0]]}")
    psi = _number("psi", graph.psi)
    if not 0.0 < psi <= 1.0:
        raise ValueError(f"psi must be in (0, 1], got {psi}")
    alpha = _number("alpha", graph.alpha)
    if alpha < 0:
        raise ValueError(f"alpha must be >= 0, got {alpha}")
    return Graph(base, nodes, rewards, psi, alpha)


def from_dict(data) -> Graph:
    """Parse the JSON object ``{"base", "nodes", "rewards", "psi", "alpha"}`` into a validated graph."""
    if not isinstance(data, dict):
        raise TypeError(f"graph file must hold a JSON object, got {type(data).__name__}")
    for key in _KEYS:
        if key not in data:
            raise ValueError(f"graph file is missing the key {key!r} (required: {', '.join(_KEYS)})")
    return validate(Graph(data["base"], data["nodes"], data["rewards"], data["psi"], data["alpha"]))


def to_dict(graph: Graph) -> dict:
    return {"base": [float(x) for x in graph.base], "nodes": np.asarray(graph.nodes, float).tolist(),
            "rewards": np.asarray(graph.rewards, float).tolist(), "psi": float(graph.psi),
            "alpha": float(graph.alpha)}


def load(path) -> Graph:
    """Read and validate a graph JSON file."""
    with open(path) as f:
        try:
            data = json.load(f)
        except json.JSONDecodeError as e:
            raise ValueError(f"graph file {path} is not valid JSON: {e}") from None
    return from_dict(data)


def save(graph: Graph, path) -> None:
    """Write a graph JSON file atomically (temp file, then ``os.replace``)."""
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        json.dump(to_dict(graph), f)
    os.replace(tmp, path)
