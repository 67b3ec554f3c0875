"""Risk-map generators and seeded map sets: instance distributions for the grid problems.

The thesis trains one network per risk map and budget (sections 4.5, 5.5);
its conclusion names the consequence as an open problem ("the network does
not really understand what energy level means"). A generator is a small,
validated, hashable object that draws an ``N x N`` risk map from a key,
inside jit and under vmap, in the spirit of jumanji's generators:

* :class:`Preset` -- one of the thesis' maps (Table 4.2: ``low``, ``medium``, ``high``);
* :class:`Rings` -- thesis-like maps: risk grows ring by ring away from the
  base, with random ring values (the shape of Table 4.2, other numbers);
* :class:`UniformRisk` -- every cell independently uniform on ``[low, high]``;
* :class:`Bumps` -- smooth random fields: a sum of Gaussian bumps, clipped;
* :class:`Mixture` -- one of several generators, drawn with given weights.

Every map has base risk 0 and risks in ``[0, max_risk]`` with ``max_risk < 1``.

A :class:`SeedSet` names a finite set of maps by integer seeds: map ``s`` of a
generator is ``generator.sample(fold_in(PRNGKey(0), s), N)``, so the same seed
always gives the same map. :func:`split_seeds` makes disjoint training and
test sets (as Procgen and XLand-MiniGrid split their levels), and
:func:`check_disjoint` refuses a training set that touches a test set.
:func:`make_maps` draws a set of maps as one array ``[M, N, N]``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxdc.core import grid
from jaxdc.core.validate import SEED_MAX, check_float, check_int, value_text

#: The largest risk a generated map may hold: a risk of 1 makes a cell a certain loss (Dijkstra's weight is
#: then infinite), which no generator here produces.
MAX_GENERATED_RISK = 0.99


def _check_risk_range(owner: str, low: float, high: float) -> tuple[float, float]:
    low = check_float(f"{owner}.low", low, 0.0, MAX_GENERATED_RISK)
    high = check_float(f"{owner}.high", high, 0.0, MAX_GENERATED_RISK)
    if low > high:
        raise ValueError(f"{owner}: low ({value_text(low)}) must not exceed high ({value_text(high)})")
    return low, high


def _with_base(risk: jax.Array) -> jax.Array:
    """``risk`` (float32) with the base cell ``(0, 0)`` at 0."""
    return risk.astype(jnp.float32).at[0, 0].set(0.0)


class RiskGenerator:
    """Base of the risk-map generators: ``sample(key, grid_size) -> [N, N]`` float32, pure and vmappable.

    Subclasses are frozen dataclasses (hashable, comparable: a generator may be part of an environment's
    static configuration) validated in ``__post_init__``; :meth:`describe` gives a JSON-able record.
    """

    name = "generator"

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """A JSON-able description: ``{"kind": ..., <fields>}``."""
        out: dict[str, Any] = {"kind": self.name}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            v = getattr(self, f.name)
            if isinstance(v, tuple) and v and isinstance(v[0], RiskGenerator):
                v = [g.describe() for g in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out


@dataclasses.dataclass(frozen=True)
class Preset(RiskGenerator):
    """The thesis map ``preset`` of Table 4.2 (``low``, ``medium``, ``high``), whatever the key."""

    preset: str = "high"
    name = "preset"

    def __post_init__(self) -> None:
        if self.preset not in grid.RISK_PRESETS:
            raise ValueError(f"Preset.preset must be one of {sorted(grid.RISK_PRESETS)}, got {self.preset!r}")

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        return jnp.asarray(grid.risk_map(self.preset, grid_size))


@dataclasses.dataclass(frozen=True)
class SkewedRisk(RiskGenerator):
    """Base of the generators whose risks are ``low + (high - low) * u**power`` for ``u`` uniform on ``[0, 1]``
    (``power = 1``: uniform on ``[low, high]``; ``power > 1`` favours small risks, as the thesis' maps do)."""

    low: float = 0.0
    high: float = 0.5
    power: float = 1.0

    def __post_init__(self) -> None:
        owner = type(self).__name__
        _check_risk_range(owner, self.low, self.high)
        check_float(f"{owner}.power", self.power, 0.0, 100.0, low_open=True)

    def draw(self, key: jax.Array, shape: tuple[int, ...]) -> jax.Array:
        """Risks of ``shape``, skewed as the class says."""
        return self.low + (self.high - self.low) * jax.random.uniform(key, shape) ** self.power


@dataclasses.dataclass(frozen=True)
class Rings(SkewedRisk):
    """Thesis-like maps (Table 4.2's shape): four rings of growing distance from the base, ring ``i`` at risk
    ``rho_i``; the four values are drawn skewed (:class:`SkewedRisk`) and sorted, so risk grows outwards."""

    high: float = 0.7
    power: float = 2.0
    name = "rings"

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        rho = jnp.sort(self.draw(key, (4,)))
        return _with_base(rho[jnp.asarray(grid.ring_index(grid_size))])


@dataclasses.dataclass(frozen=True)
class UniformRisk(SkewedRisk):
    """Every cell's risk drawn independently (:class:`SkewedRisk`; base 0)."""

    name = "uniform"

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        return _with_base(self.draw(key, (grid_size, grid_size)))


@dataclasses.dataclass(frozen=True)
class Bumps(RiskGenerator):
    """Smooth random fields: ``floor`` plus ``count`` Gaussian bumps, clipped to ``[0, cap]`` (base 0).

    ``count`` is drawn uniformly from ``min_count..max_count``; each bump has a uniform centre on the grid,
    a height uniform on ``[0, max_height]`` and a width (standard deviation, in cells) uniform on
    ``[min_width, max_width]``.
    """

    min_count: int = 1
    max_count: int = 4
    max_height: float = 0.6
    min_width: float = 0.7
    max_width: float = 2.5
    floor: float = 0.01
    cap: float = 0.9
    name = "bumps"

    def __post_init__(self) -> None:
        check_int("Bumps.min_count", self.min_count, 1, 64)
        check_int("Bumps.max_count", self.max_count, 1, 64)
        if self.min_count > self.max_count:
            raise ValueError(f"Bumps: min_count ({self.min_count}) must not exceed max_count ({self.max_count})")
        check_float("Bumps.max_height", self.max_height, 0.0, MAX_GENERATED_RISK)
        check_float("Bumps.min_width", self.min_width, 0.0, 1e3, low_open=True)
        check_float("Bumps.max_width", self.max_width, 0.0, 1e3, low_open=True)
        if self.min_width > self.max_width:
            raise ValueError(f"Bumps: min_width ({value_text(self.min_width)}) must not exceed max_width "
                             f"({value_text(self.max_width)})")
        check_float("Bumps.cap", self.cap, 0.0, MAX_GENERATED_RISK)
        check_float("Bumps.floor", self.floor, 0.0, self.cap)

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        n, m = grid_size, self.max_count
        k_count, k_pos, k_height, k_width = jax.random.split(key, 4)
        count = jax.random.randint(k_count, (), self.min_count, self.max_count + 1)
        centre = jax.random.uniform(k_pos, (m, 2), maxval=n - 1.0)
        height = jax.random.uniform(k_height, (m,), maxval=self.max_height) * (jnp.arange(m) < count)
        width = jax.random.uniform(k_width, (m,), minval=self.min_width, maxval=self.max_width)
        rc = jnp.stack(jnp.meshgrid(jnp.arange(n), jnp.arange(n), indexing="ij"), -1).astype(jnp.float32)
        d2 = jnp.sum((rc[None] - centre[:, None, None, :]) ** 2, -1)  # [m, n, n]
        field = self.floor + jnp.sum(height[:, None, None] * jnp.exp(-d2 / (2 * width[:, None, None] ** 2)), 0)
        return _with_base(jnp.clip(field, 0.0, self.cap))


@dataclasses.dataclass(frozen=True)
class Mixture(RiskGenerator):
    """One of ``generators``, drawn with probabilities proportional to ``weights`` (equal if empty)."""

    generators: tuple = ()
    weights: tuple = ()
    name = "mixture"

    def __post_init__(self) -> None:
        if not isinstance(self.generators, tuple) or not self.generators:
            raise ValueError(f"Mixture.generators must be a non-empty tuple of generators, got {self.generators!r}")
        for g in self.generators:
            if not isinstance(g, RiskGenerator):
                raise TypeError(f"Mixture.generators must hold RiskGenerator objects, got {g!r}")
        if self.weights:
            if len(self.weights) != len(self.generators):
                raise ValueError(f"Mixture.weights must have one weight per generator ({len(self.generators)}), "
                                 f"got {len(self.weights)}")
            for i, w in enumerate(self.weights):
                check_float(f"Mixture.weights[{i}]", w, 0.0)
            if sum(self.weights) <= 0:
                raise ValueError(f"Mixture.weights must not all be 0, got {self.weights!r}")

    def sample(self, key: jax.Array, grid_size: int) -> jax.Array:
        k_which, k_map = jax.random.split(key)
        w = jnp.asarray(self.weights or (1.0,) * len(self.generators), jnp.float32)
        which = jax.random.choice(k_which, len(self.generators), p=w / w.sum())
        maps = jnp.stack([g.sample(k_map, grid_size) for g in self.generators])
        return maps[which]


#: Named generators for the command line (``--risk-maps NAME``); each is documented in docs/generalisation.md.
GENERATORS: dict[str, RiskGenerator] = {
    "thesis": Mixture((Preset("low"), Preset("medium"), Preset("high"))),
    "rings": Rings(),
    "uniform": UniformRisk(),
    "bumps": Bumps(),
    # the training family of enn_general: thesis-like rings, uniform noise and smooth fields, plus the thesis'
    # own three maps (they are evaluation settings of the tables, not held-out maps)
    "mix": Mixture((Rings(), UniformRisk(0.0, 0.5, power=3.0), Bumps(),
                    Preset("low"), Preset("medium"), Preset("high")),
                   (3.0, 2.0, 3.0, 0.33, 0.33, 0.34)),
}


def generator(name: str) -> RiskGenerator:
    """The named generator of :data:`GENERATORS`."""
    if name not in GENERATORS:
        raise ValueError(f"risk_maps must be one of {tuple(GENERATORS)}, got {name!r}")
    return GENERATORS[name]


#: The most map seeds one :class:`SeedSet` holds.
MAX_SEED_COUNT = 1 << 20


@dataclasses.dataclass(frozen=True)
class SeedSet:
    """The map seeds ``start .. start + count - 1``."""

    start: int = 0
    count: int = 1024

    def __post_init__(self) -> None:
        check_int("SeedSet.start", self.start, 0, SEED_MAX)
        check_int("SeedSet.count", self.count, 1, MAX_SEED_COUNT)
        if self.start + self.count - 1 > SEED_MAX:
            raise ValueError(f"SeedSet: start + count - 1 must be <= {SEED_MAX}, got {self.start + self.count - 1}")

    @property
    def stop(self) -> int:
        return self.start + self.count

    def seeds(self) -> np.ndarray:
        return np.arange(self.start, self.stop, dtype=np.uint32)

    def overlaps(self, other: SeedSet) -> bool:
        return self.start < other.stop and other.start < self.stop


#: Where the test seeds of :func:`split_seeds` start: far above any training set it makes.
TEST_SEED_START = 1 << 30


def split_seeds(train: int, test: int) -> tuple[SeedSet, SeedSet]:
    """Disjoint training and test map seeds: ``0 .. train-1`` and ``2**30 .. 2**30 + test - 1``."""
    check_int("train", train, 1, TEST_SEED_START)
    return SeedSet(0, train), SeedSet(TEST_SEED_START, check_int("test", test, 1, MAX_SEED_COUNT))


def check_disjoint(train: SeedSet, test: SeedSet) -> None:
    """``ValueError`` if the training seeds touch the test seeds."""
    if train.overlaps(test):
        raise ValueError(f"the training map seeds {train.start}..{train.stop - 1} overlap the held-out test seeds "
                         f"{test.start}..{test.stop - 1}")


def map_key(seed: jax.Array | int) -> jax.Array:
    """The key of map ``seed`` (independent of every episode key)."""
    return jax.random.fold_in(jax.random.PRNGKey(0), jnp.asarray(seed, jnp.uint32))


def make_maps(gen: RiskGenerator, seeds: SeedSet, grid_size: int) -> np.ndarray:
    """The maps of ``seeds`` under ``gen``: ``[M, N, N]`` float32 (deterministic by seed)."""
    if not isinstance(gen, RiskGenerator):
        raise TypeError(f"generator must be a RiskGenerator, got {gen!r}")
    grid.check_grid_size(grid_size)
    draw = jax.jit(jax.vmap(lambda s: gen.sample(map_key(s), grid_size)))
    return np.asarray(draw(jnp.asarray(seeds.seeds())))


__all__ = ["GENERATORS", "MAX_GENERATED_RISK", "MAX_SEED_COUNT", "TEST_SEED_START", "Bumps", "Mixture", "Preset",
           "RiskGenerator", "Rings", "SeedSet", "SkewedRisk", "UniformRisk", "check_disjoint", "generator", "make_maps",
           "map_key", "split_seeds"]
