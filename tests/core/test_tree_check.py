"""jaxdc.core.tree_check: one comparison of leaf paths and shapes, for parameter files and checkpoints."""

from __future__ import annotations

import numpy as np
import pytest

from jaxdc.core.tree_check import Mismatch, check_like, mismatch

TEMPLATE = {"a": {"w": np.zeros((2, 3)), "b": np.zeros(3)}, "c": np.zeros(())}


def test_mismatch():
    assert mismatch(TEMPLATE, {"c": np.ones(()), "a": {"b": np.ones(3), "w": np.ones((2, 3))}}) is None
    assert mismatch(TEMPLATE, {"a": {"w": np.zeros((2, 3))}, "c": 0.0, "d": 1}) == Mismatch(
        ["['a']['b']"], ["['d']"])
    assert mismatch(TEMPLATE, {"a": {"w": np.zeros((3, 2)), "b": np.zeros(4)}, "c": 0.0}) == Mismatch(
        [], [], "['a']['b']", (4,), (3,))
    slash = mismatch(TEMPLATE, {"a": {"w": np.zeros((2, 3))}, "c": 0.0},
                     key=lambda path: "".join(f"/{k.key}" for k in path))
    assert slash.missing == ["/a/b"]


def test_check_like():
    out = check_like(TEMPLATE, {"a": {"w": np.ones((2, 3), np.float64), "b": np.ones(3)}, "c": 1}, "f", "a net")
    assert out["a"]["w"].dtype == np.float32
    missing = r"^f: the parameters are not those of a net \(missing \[\"\['c'\]\"\], unexpected \[\]\)$"
    with pytest.raises(ValueError, match=missing):
        check_like(TEMPLATE, {"a": {"w": np.ones((2, 3)), "b": np.ones(3)}}, "f", "a net")
    with pytest.raises(ValueError, match=r"parameter \['a'\]\['w'\] has shape \(3, 2\), expected \(2, 3\) for a net "
                                         r"\(other grid\?\)$"):
        check_like(TEMPLATE, {"a": {"w": np.ones((3, 2)), "b": np.ones(3)}, "c": 1}, "f", "a net", "other grid?")
