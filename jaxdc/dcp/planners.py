"""Planning algorithms on the DCP grid (section 4.4.1-4.4.2).

A *planner* looks at the agent's cell and the items and returns
``Plan(action, target, length)``: the first action of a path, the flat index
of the cell it leads to, and the number of moves of that path.

* :func:`lpg` -- Loss-Per-Gain, Algorithm 7, on the complete graph of safest
  paths (Fig. 4.2); the other append criteria of chapter 3 (NG, OSA, TL, GML,
  Table 4.1) come from the same code through :func:`tour_planner`.
* :func:`cf` -- Closest-First, Algorithm 8.
* :func:`safe_home` / :func:`fast_home` -- the safest and the shortest path
  back to the base (section 4.4.2).

Items are addressed by flat cell index (row-major); "item order" for ties is
that order. All functions are pure and jittable; ``PlannerConfig`` holds the
static readings of the ambiguous parts of the thesis.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
from flax import struct

from jaxdc.core import grid
from jaxdc.core.paths import PathTable
from jaxdc.core.tour_criteria import APPEND_CRITERIA, append_scores
from jaxdc.core.validate import check_float

CF_DISTANCES = ("chebyshev", "manhattan")


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
    """Static readings of the thesis' ambiguities for the planners (docs/ambiguities.md).

    Attributes:
      cf_distance: CF's distance. Algorithm 8 computes Chebyshev
        (``max(|dx|, |dy|)``), the text of 4.4.2 says Manhattan.
      shortest_move: the "shortest path" move, ``"diagonal"`` (diagonal first)
        or ``"order"`` (first action in the thesis' order); see
        :func:`jaxdc.core.grid.shortest_move`.
      lpg_init: LPG's initial loss sum; Algorithm 7 writes ``+inf`` (every
        item ties, so the first item wins), read as a typo for 0. Any real
        number or ``+inf``; NaN and ``-inf`` are refused.
      tie_rtol: scores within this relative tolerance of the best count as
        tied, and ties go to the first item in row-major order (finite, >= 0).
    """

    cf_distance: str = "chebyshev"
    shortest_move: str = "diagonal"
    lpg_init: float = 0.0
    tie_rtol: float = 1e-5

    def __post_init__(self):
        if self.cf_distance not in CF_DISTANCES:
            raise ValueError(f"cf_distance must be one of {CF_DISTANCES}, got {self.cf_distance!r}")
        if self.shortest_move not in grid.SHORTEST_MOVE_RULES:
            raise ValueError(
                f"shortest_move must be one of {grid.SHORTEST_MOVE_RULES}, got {self.shortest_move!r}"
            )
        check_float("lpg_init", self.lpg_init, allow_inf=True)
        check_float("tie_rtol", self.tie_rtol, low=0.0)


@struct.dataclass
class Plan:
    action: jnp.ndarray  # int32 first action
    target: jnp.ndarray  # int32 flat index of the target cell
    length: jnp.ndarray  # int32 number of moves to the target


def first_best(score, rtol: float, rank=None):
    """Index of the best entry; entries within ``rtol`` (relative) of the maximum tie,
    and ties go to the lowest ``rank`` (item order; the lowest index if ``rank`` is None)."""
    best = jnp.max(score)
    tol = rtol * jnp.maximum(jnp.abs(best), 1e-30)
    tied = score >= best - tol
    if rank is None:
        return jnp.argmax(tied).astype(jnp.int32)
    return jnp.argmin(jnp.where(tied, rank.reshape(-1), jnp.iinfo(jnp.int32).max)).astype(jnp.int32)


def tour_planner(criterion: str):
    """The planner that follows the safest path to the item chosen by an append criterion.

    ``criterion`` is one of ``ng, osa, tl, gml, lpg`` (Eqs. 3.2-3.7) applied
    to the complete graph whose edge weights are safest-path success
    probabilities (section 4.4.1, Fig. 4.2); ``lpg`` is Algorithm 7.
    """
    if criterion not in APPEND_CRITERIA:
        raise ValueError(f"criterion must be one of {APPEND_CRITERIA}, got {criterion!r}")

    def planner(pos, items, table: PathTable, cfg: PlannerConfig = PlannerConfig(), rank=None) -> Plan:
        n = items.shape[0]
        z = grid.flat_index(pos, n)
        beta = items.reshape(-1)
        score = append_scores(
            criterion, table.success[z], table.success, beta, beta > 0, lpg_init=cfg.lpg_init
        )
        target = jnp.where(jnp.any(beta > 0), first_best(score, cfg.tie_rtol, rank), z).astype(jnp.int32)
        return Plan(table.next_action[z, target], target, table.steps[z, target])

    planner.__name__ = criterion
    planner.__doc__ = f"Planner {criterion.upper()} on the safest-path graph (section 4.4.1)."
    return planner


#: Loss-Per-Gain, Algorithm 7.
lpg = tour_planner("lpg")


def cf(pos, items, table: PathTable | None = None, cfg: PlannerConfig = PlannerConfig(), rank=None) -> Plan:
    """Closest-First, Algorithm 8: the nearest item (first in item order ``rank``), by the shortest path."""
    n = items.shape[0]
    cells = grid.cell_coords(n)
    dist = grid.chebyshev(cells, pos) if cfg.cf_distance == "chebyshev" else grid.manhattan(cells, pos)
    has_item = items.reshape(-1) > 0
    rank = jnp.arange(n * n) if rank is None else rank.reshape(-1)
    key = jnp.where(has_item, dist * (n * n) + rank, jnp.iinfo(jnp.int32).max)
    target = jnp.where(jnp.any(has_item), jnp.argmin(key), grid.flat_index(pos, n))
    tpos = grid.unflat_index(target, n)
    return Plan(
        grid.shortest_move(pos, tpos, n, cfg.shortest_move),
        target.astype(jnp.int32),
        grid.chebyshev(pos, tpos).astype(jnp.int32),
    )


def safe_home(pos, grid_size: int, table: PathTable, cfg: PlannerConfig = PlannerConfig()) -> Plan:
    """The safest path back to the base (section 4.4.2)."""
    z = grid.flat_index(pos, grid_size)
    return Plan(table.next_action[z, 0], jnp.int32(0), table.steps[z, 0])


def fast_home(pos, grid_size: int, table: PathTable | None = None, cfg: PlannerConfig = PlannerConfig()) -> Plan:
    """The shortest path back to the base (section 4.4.2)."""
    base = jnp.zeros(2, jnp.int32)
    return Plan(
        grid.shortest_move(pos, base, grid_size, cfg.shortest_move),
        jnp.int32(0),
        grid.chebyshev(pos, base).astype(jnp.int32),
    )
