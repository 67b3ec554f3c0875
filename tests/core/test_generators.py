"""Risk-map generators and seeded map sets (jaxdc.core.generators)."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import generators as G


@pytest.mark.parametrize("name", sorted(G.GENERATORS))
def test_every_named_generator_makes_valid_maps_deterministically(name):
    gen = G.generator(name)
    a = G.make_maps(gen, G.SeedSet(0, 64), 8)
    b = G.make_maps(gen, G.SeedSet(0, 64), 8)
    assert a.shape == (64, 8, 8) and a.dtype == np.float32
    np.testing.assert_array_equal(a, b)
    assert np.all(a[:, 0, 0] == 0)
    assert a.min() >= 0 and a.max() <= G.MAX_GENERATED_RISK
    json.dumps(gen.describe())


def test_a_seed_names_one_map_whatever_the_set_around_it():
    gen = G.generator("mix")
    wide = G.make_maps(gen, G.SeedSet(0, 32), 6)
    one = G.make_maps(gen, G.SeedSet(17, 1), 6)
    np.testing.assert_allclose(wide[17], one[0], atol=1e-6)  # vectorised maths may differ in the last bit


def test_generators_differ_across_seeds_and_run_under_jit_and_vmap():
    gen = G.Bumps()
    keys = jax.vmap(G.map_key)(jnp.arange(8, dtype=jnp.uint32))
    maps = jax.jit(jax.vmap(lambda k: gen.sample(k, 5)))(keys)
    assert maps.shape == (8, 5, 5)
    assert len({np.asarray(m).tobytes() for m in maps}) == 8


def test_rings_grow_outwards_and_presets_are_the_thesis_maps():
    m = np.asarray(G.Rings().sample(jax.random.PRNGKey(3), 8))
    from jaxdc.core import grid
    ring = grid.ring_index(8)
    by_ring = [m[(ring == r) & ~((np.arange(8)[:, None] == 0) & (np.arange(8)[None, :] == 0))].mean() for r in range(4)]
    assert by_ring == sorted(by_ring)
    np.testing.assert_array_equal(np.asarray(G.Preset("medium").sample(jax.random.PRNGKey(0), 8)),
                                  grid.risk_map("medium", 8))


def test_mixture_draws_each_component():
    mix = G.Mixture((G.Preset("low"), G.Preset("high")), (1.0, 1.0))
    maps = G.make_maps(mix, G.SeedSet(0, 200), 8)
    from jaxdc.core import grid
    low = np.all(maps == grid.risk_map("low", 8), axis=(1, 2))
    high = np.all(maps == grid.risk_map("high", 8), axis=(1, 2))
    assert np.all(low | high) and 60 < low.sum() < 140


@pytest.mark.parametrize("make, match", [
    (lambda: G.UniformRisk(0.5, 0.2), "UniformRisk: low"),
    (lambda: G.UniformRisk(0.0, 1.0), "UniformRisk.high"),
    (lambda: G.Rings(-0.1, 0.5), "Rings.low"),
    (lambda: G.Bumps(min_count=3, max_count=2), "min_count"),
    (lambda: G.Bumps(min_width=0.0), "Bumps.min_width"),
    (lambda: G.Mixture(()), "Mixture.generators"),
    (lambda: G.Mixture((G.Rings(),), (1.0, 2.0)), "Mixture.weights"),
    (lambda: G.Mixture((G.Rings(),), (0.0,)), "must not all be 0"),
    (lambda: G.Preset("extreme"), "Preset.preset"),
    (lambda: G.SeedSet(-1, 4), "SeedSet.start"),
    (lambda: G.SeedSet(0, 0), "SeedSet.count"),
    (lambda: G.generator("nope"), "risk_maps"),
    (lambda: G.UniformRisk(float("nan"), 0.2), "UniformRisk.low"),
])
def test_bad_generator_parameters_are_refused_by_name(make, match):
    with pytest.raises((ValueError, TypeError), match=match):
        make()


def test_mixture_refuses_a_non_generator():
    with pytest.raises(TypeError, match="RiskGenerator"):
        G.Mixture(("high",))


def test_split_is_disjoint_and_overlap_is_refused():
    train, test = G.split_seeds(1024, 64)
    assert not train.overlaps(test)
    G.check_disjoint(train, test)
    with pytest.raises(ValueError, match="overlap the held-out"):
        G.check_disjoint(G.SeedSet(G.TEST_SEED_START - 2, 4), test)


def test_generators_are_hashable_static_configuration():
    assert hash(G.Bumps()) == hash(G.Bumps()) and G.Bumps() == G.Bumps()
    assert G.Bumps(max_count=3) != G.Bumps()
