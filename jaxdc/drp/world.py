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
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core.validate import check_choice, value_text
from jaxdc.io import atomic_write, json_text

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
    check_choice("rewards", rewards, sorted(REWARD_SETTINGS))
    check_choice("base", base, BASE_LOCATIONS)
    if not (isinstance(n, numbers.Integral) and not isinstance(n, bool) and 1 <= n <= MAX_NODES):
        raise ValueError(f"n must be an integer in [1, {MAX_NODES}], got {n!r}")
    if not (isinstance(seed, numbers.Integral) and not isinstance(seed, bool) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    size = _number("size", size, 0.0, COORD_MAX)
    if size <= 0:
        raise ValueError(f"size must be in (0, {COORD_MAX:g}], got {value_text(size)}")
    rng = np.random.default_rng(seed)
    nodes = rng.uniform(0.0, size, size=(n, 2))
    lo, hi = REWARD_SETTINGS[rewards]
    beta = rng.integers(lo, hi + 1, size=n).astype(np.float64)
    b = np.zeros(2) if base == "corner" else np.full(2, size / 2)
    return validate(Graph(b, nodes, beta, psi, alpha))


# ----------------------------------------------------------------------------- validation and JSON

_KEYS = ("base", "nodes", "rewards", "psi", "alpha")

#: Largest ``|x|``, ``|y|`` of the base and of a node. Every planner works in float32 (largest finite value
#: about 3.4e38): with coordinates within 1e9 a distance is at most 2.9e9 (its squared components at most
#: 8e18), a tour over at most MAX_NODES + 1 edges is shorter than 1e14, and products of a length and a
#: value (the criteria of Eqs. 3.2-3.7) stay below 1e23.
COORD_MAX = 1e9
#: Largest node reward and robot value alpha. The sums of Eq. 3.1 are at most
#: ``sum(rewards) + n * alpha <= 2 * MAX_NODES * VALUE_MAX < 7e13``, far from float32 overflow.
VALUE_MAX = 1e9
#: Most nodes a graph may have (the distance matrix alone is ``4 (n + 1)^2`` bytes: 4 GB at this bound).
MAX_NODES = 2**15
#: Smallest survival probability per unit distance: the smallest normal float32 (a smaller psi is 0 in float32).
PSI_MIN = float(np.finfo(np.float32).tiny)


def _number(name, value, low=None, high=None):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an int too large for a float
        raise ValueError(f"{name} must be a finite number, got an integer of {len(str(abs(int(value))))} "
                         f"digits") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if (low is not None and v < low) or (high is not None and v > high):
        raise ValueError(f"{name} must be in [{value_text(low)}, {value_text(high)}] (so that the float32 planners "
                         "stay finite), "
                         f"got {value_text(v)}")
    return v


def _point(name, value):
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2:
        raise ValueError(f"{name} must be a pair [x, y], got {value!r}")
    return [_number(f"{name}[{i}]", v, -COORD_MAX, COORD_MAX) for i, v in enumerate(value)]


def validate(graph: Graph) -> Graph:
    """Check a graph and return it with numpy arrays; ``ValueError``/``TypeError`` name the field.

    Coordinates must be finite numbers within ``±COORD_MAX``, rewards and alpha finite in
    ``[0, VALUE_MAX]``, psi in ``[PSI_MIN, 1]`` and the graph must have ``1 .. MAX_NODES`` nodes, so that the
    distances, tour lengths and sums of Eq. 3.1 stay finite in float32. Booleans are refused.
    """
    base_in = graph.base.tolist() if isinstance(graph.base, np.ndarray) else graph.base
    base = np.asarray(_point("base", base_in))
    nodes_in = graph.nodes.tolist() if isinstance(graph.nodes, np.ndarray) else graph.nodes
    if not isinstance(nodes_in, (list, tuple)):
        raise TypeError(f"nodes must be a list of [x, y] pairs, got {type(nodes_in).__name__}")
    if len(nodes_in) == 0:
        raise ValueError("nodes must be a non-empty list of [x, y] pairs, got an empty list")
    if len(nodes_in) > MAX_NODES:
        raise ValueError(f"nodes must hold at most {MAX_NODES} nodes, got {len(nodes_in)}")
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
    bad = np.flatnonzero(rewards > VALUE_MAX)
    if bad.size:
        raise ValueError(f"rewards[{bad[0]}] must be in [0, {VALUE_MAX:g}] (so that the float32 planners stay "
                         f"finite), got {value_text(rewards[bad[0]])}")
    psi = _number("psi", graph.psi)
    if not 0.0 < psi <= 1.0:
        raise ValueError(f"psi must be in (0, 1], got {psi}")
    if psi < PSI_MIN:
        raise ValueError(f"psi must be >= {PSI_MIN:.4g} (the smallest normal float32; a smaller one is 0 "
                         f"there), got {value_text(psi)}")
    alpha = _number("alpha", graph.alpha)
    if alpha < 0:
        raise ValueError(f"alpha must be >= 0, got {alpha}")
    if alpha > VALUE_MAX:
        raise ValueError(f"alpha must be in [0, {VALUE_MAX:g}] (so that the float32 planners stay finite), "
                         f"got {value_text(alpha)}")
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
    # read leniently: a NaN or Infinity in the file is refused by validate(), which names the field (base[1])
    try:
        with open(path) as f:
            data = json.load(f)
    except json.JSONDecodeError as e:
        raise ValueError(f"graph file {path} is not valid JSON: {e}") from None
    except RecursionError:
        raise ValueError(f"graph file {path}: nested too deeply to be read (a graph is an object of flat lists)") \
            from None
    except (OSError, UnicodeDecodeError) as e:
        raise ValueError(f"graph file {path}: cannot read it: {e}") from None
    unknown = sorted(set(data) - set(_KEYS)) if isinstance(data, dict) else []
    if unknown:
        raise ValueError(f"graph file {path}: unknown key {unknown[0]!r} (allowed: {', '.join(_KEYS)})")
    return from_dict(data)


def save(graph: Graph, path) -> None:
    """Write a graph JSON file atomically (same-folder temp file, then ``os.replace``; strict JSON).

    An interruption leaves the old file or the complete new one, never a temporary file.
    """
    atomic_write(path, json_text(to_dict(validate(graph)), indent=None))
