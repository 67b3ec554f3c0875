"""uniform_index (multiply-shift) and drop_units (multinomial drop with first-drop order)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from jaxdc.core.sampling import drop_units, uniform_index


@pytest.mark.parametrize("n", [1, 2, 25, 64, 1000, 65535])
def test_uniform_index_range(n):
    x = np.asarray(uniform_index(jax.random.PRNGKey(n), (20000,), n))
    assert x.min() >= 0 and x.max() < n


def test_uniform_index_is_floor_u_n_over_2_32():
    u = jax.random.bits(jax.random.PRNGKey(3), (1000,), jnp.uint32)
    got = np.asarray(uniform_index(jax.random.PRNGKey(3), (1000,), 1000))
    want = (np.asarray(u).astype(np.uint64) * 1000) >> 32
    np.testing.assert_array_equal(got, want.astype(np.int64))


def test_uniform_index_uniform_chi_square():
    x = np.asarray(uniform_index(jax.random.PRNGKey(0), (50000,), 25))
    counts = np.bincount(x, minlength=25)
    assert stats.chisquare(counts).pvalue > 1e-4


def test_drop_units_counts_and_first_order():
    counts, first = drop_units(jax.random.PRNGKey(5), 30, 64)
    counts, first = np.asarray(counts), np.asarray(first)
    assert counts.sum() == 30
    hit = counts > 0
    assert np.all(first[~hit] == 30)
    # the first-drop indices of the hit cells are distinct and include 0 (the first unit)
    assert len(set(first[hit])) == hit.sum() and 0 in first[hit]


def test_drop_units_low_excludes_cells():
    counts, _ = drop_units(jax.random.PRNGKey(1), 500, 9, low=1)
    assert float(counts[0]) == 0.0 and float(counts.sum()) == 500


def test_drop_units_count_keeps_the_first_draws():
    key = jax.random.PRNGKey(7)
    full, full_first = drop_units(key, 30, 64)
    part, part_first = drop_units(key, 30, 64, count=jnp.int32(4))
    part, part_first, full_first = np.asarray(part), np.asarray(part_first), np.asarray(full_first)
    assert part.sum() == 4 and np.all(part <= np.asarray(full))
    # the kept units are draws 0..3 of the full drop: the same cells, the same first-drop order
    assert sorted(part_first[part > 0]) == sorted(full_first[full_first < 4])
    assert np.all(part_first[part == 0] == 30)


@pytest.mark.parametrize("n", [1, 2, 64, 1024, 1025, 4096])
def test_running_count_equals_cumsum(n):
    from jaxdc.core.sampling import running_count

    masks = jax.random.bernoulli(jax.random.PRNGKey(n), 0.7, (8, n))
    got = jax.vmap(running_count)(masks)
    assert got.dtype == jnp.int32
    np.testing.assert_array_equal(np.asarray(got), np.cumsum(np.asarray(masks), axis=-1))
