"""jaxdc.core.grid: actions, clipping, distances, shortest moves, risk maps (section 4.3, Table 4.2, Fig. 4.1b)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.core import grid

# Fig. 4.1b, typed from the thesis.
FIG_4_1B = np.array(
    [
        [0.00, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01],
        [0.01, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.01],
        [0.01, 0.04, 0.16, 0.16, 0.16, 0.16, 0.04, 0.01],
        [0.01, 0.04, 0.16, 0.64, 0.64, 0.16, 0.04, 0.01],
        [0.01, 0.04, 0.16, 0.64, 0.64, 0.16, 0.04, 0.01],
        [0.01, 0.04, 0.16, 0.16, 0.16, 0.16, 0.04, 0.01],
        [0.01, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.01],
        [0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01],
    ]
)
TABLE_4_2 = {"low": (0.01, 0.02, 0.04, 0.08), "medium": (0.01, 0.03, 0.09, 0.27), "high": (0.01, 0.04, 0.16, 0.64)}


def test_action_order_and_deltas():
    assert grid.ACTIONS == ("stay", "up", "down", "left", "right", "up_left", "up_right", "down_left", "down_right")
    assert grid.NUM_ACTIONS == 9 and grid.STAY == 0
    expected = {"stay": (0, 0), "up": (-1, 0), "down": (1, 0), "left": (0, -1), "right": (0, 1),
                "up_left": (-1, -1), "up_right": (-1, 1), "down_left": (1, -1), "down_right": (1, 1)}
    for a, name in enumerate(grid.ACTIONS):
        assert tuple(int(v) for v in grid.DELTAS_NP[a]) == expected[name]


A = {name: i for i, name in enumerate(grid.ACTIONS)}


@pytest.mark.parametrize(
    "pos, action, expected",
    [
        ((3, 3), "up", (2, 3)),
        ((3, 3), "down_left", (4, 2)),
        ((0, 3), "up_left", (0, 2)),  # top edge: still moves left
        ((0, 3), "up", (0, 3)),
        ((0, 0), "up_left", (0, 0)),  # corner: no move at all
        ((7, 7), "down_right", (7, 7)),
        ((7, 3), "down_right", (7, 4)),
        ((3, 0), "down_left", (4, 0)),
        ((0, 7), "up_right", (0, 7)),
        ((5, 7), "up_right", (4, 7)),
        ((2, 0), "left", (2, 0)),
        ((4, 4), "stay", (4, 4)),
    ],
)
def test_move_clips_per_axis(pos, action, expected):
    out = grid.move(jnp.array(pos, jnp.int32), A[action], 8)
    assert tuple(int(v) for v in out) == expected


def test_neighbours_match_move():
    pos = jnp.array([0, 7], jnp.int32)
    succ = np.asarray(grid.neighbours(pos, 8))
    assert succ.shape == (9, 2)
    for a in range(9):
        np.testing.assert_array_equal(succ[a], np.asarray(grid.move(pos, a, 8)))
    assert [tuple(s) for s in succ] == [(0, 7), (0, 7), (1, 7), (0, 6), (0, 7), (0, 6), (0, 7), (1, 6), (1, 7)]


def test_distances():
    a, b = jnp.array([1, 2]), jnp.array([4, 0])
    assert int(grid.chebyshev(a, b)) == 3
    assert int(grid.manhattan(a, b)) == 5
    assert int(grid.chebyshev(a, a)) == 0
    batch = grid.chebyshev(jnp.array([[0, 0], [7, 7], [2, 5]]), jnp.array([3, 3]))
    assert list(np.asarray(batch)) == [3, 4, 2]


@pytest.mark.parametrize(
    "pos, target, diagonal, order",
    [
        ((3, 3), (3, 3), "stay", "stay"),
        ((3, 3), (0, 0), "up_left", "up_left"),
        ((3, 3), (3, 0), "left", "left"),
        ((3, 3), (5, 6), "down_right", "right"),  # right and down_right both reach 2
        # dx = -3, dy = +1: up, up_left and up_right all reach distance 2;
        # "diagonal" steps sign(dx), sign(dy), "order" takes the first in action order.
        ((3, 3), (0, 4), "up_right", "up"),
        ((3, 3), (6, 2), "down_left", "down"),
        ((3, 3), (2, 6), "up_right", "right"),
        ((3, 3), (1, 5), "up_right", "up_right"),
    ],
)
def test_shortest_move_rules(pos, target, diagonal, order):
    p, t = jnp.array(pos, jnp.int32), jnp.array(target, jnp.int32)
    for rule, expected in (("diagonal", diagonal), ("order", order)):
        a = int(grid.shortest_move(p, t, 8, rule))
        assert grid.ACTIONS[a] == expected, rule
        # it is a shortest move: the Chebyshev distance drops by one (or stays 0)
        d0 = int(grid.chebyshev(p, t))
        assert int(grid.chebyshev(grid.move(p, a, 8), t)) == max(d0 - 1, 0)


def test_shortest_move_bad_rule():
    with pytest.raises(ValueError, match="rule"):
        grid.shortest_move(jnp.array([0, 0]), jnp.array([1, 1]), 8, "zigzag")


@pytest.mark.parametrize("preset", ["low", "medium", "high"])
def test_risk_presets_equal_fig_4_1b(preset):
    rho = np.asarray(TABLE_4_2[preset])
    # Fig. 4.1b's layout with the preset's values: rings of 0.01/0.04/0.16/0.64 -> rho0..rho3.
    ring = np.searchsorted([0.01, 0.04, 0.16, 0.64], np.maximum(FIG_4_1B, 0.01))
    expected = rho[ring]
    expected[0, 0] = 0.0
    got = grid.risk_map(preset, 8)
    assert got.shape == (8, 8)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7)
    assert got[0, 0] == 0.0
    if preset == "high":
        np.testing.assert_allclose(got, FIG_4_1B, atol=1e-7)


@pytest.mark.parametrize("n", [5, 16])
def test_ring_rule_other_sizes(n):
    for preset, rho in TABLE_4_2.items():
        r = grid.risk_map(preset, n)
        assert r.shape == (n, n)
        assert r[0, 0] == 0.0
        border = np.concatenate([r[0, 1:], r[-1, :], r[1:, 0], r[:, -1]])
        np.testing.assert_allclose(border, rho[0], atol=1e-7)
        c = (n - 1) // 2
        centre = r[c : n - c, c : n - c]
        np.testing.assert_allclose(centre, rho[3], atol=1e-7)
        assert np.all(np.isclose(r[1:, 1:].ravel()[:, None], np.asarray(rho)[None, :], atol=1e-6).any(axis=1))
        # monotone towards the centre along the diagonal
        diag = np.diag(r)[1 : c + 1]
        assert np.all(np.diff(diag) >= 0)


def test_bad_preset():
    with pytest.raises(ValueError, match="preset"):
        grid.risk_map("extreme", 8)


@pytest.mark.parametrize(
    "risk, word",
    [
        (np.zeros((3, 4)), "square"),
        (np.zeros(9), "square"),
        (np.array([[0, 0.5], [0.2, 1.5]]), "[0, 1]"),
        (np.array([[0, 0.5], [-0.1, 0.2]]), "[0, 1]"),
        (np.array([[0.1, 0.5], [0.2, 0.3]]), "base"),
        (np.array([[0, np.nan], [0.2, 0.3]]), "[0, 1]"),
    ],
)
def test_validate_risk_map_errors(risk, word):
    with pytest.raises(ValueError) as e:
        grid.validate_risk_map(risk)
    assert word in str(e.value)


def test_validate_risk_map_ok_and_size_mismatch():
    r = grid.risk_map("medium", 5)
    np.testing.assert_array_equal(grid.validate_risk_map(r), r)
    with pytest.raises(ValueError, match="grid_size"):
        grid.validate_risk_map(r, 8)
    with pytest.raises(TypeError, match="risk map"):
        grid.validate_risk_map([["a", "b"], ["c", "d"]])


def test_check_grid_size():
    assert grid.check_grid_size(2) == 2
    with pytest.raises(ValueError, match="grid_size"):
        grid.check_grid_size(1)
    with pytest.raises(TypeError, match="grid_size"):
        grid.check_grid_size(2.5)
    with pytest.raises(TypeError, match="grid_size"):
        grid.check_grid_size(True)


def test_risk_map_cells_that_are_no_numbers_are_named():
    import jax.numpy as jnp

    for bad, needle in (([[0, True], [0, 0]], r"cell \(0, 1\) is a boolean: true"),
                        ([[0, 0.1], ["x", 0]], r"cell \(1, 0\) is not a number \(str\)"),
                        (np.zeros((2, 2), bool), r"cell \(0, 0\) is a boolean")):
        with pytest.raises(TypeError, match=needle):
            grid.validate_risk_map(bad)
    assert grid.validate_risk_map(jnp.zeros((3, 3))).dtype == np.float32
