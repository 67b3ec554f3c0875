"""jaxdc.dcp.env's hostile input: bad constructor arguments and parameters are refused by name, outside jit;
equality and the defaults."""

from __future__ import annotations

import numpy as np
import pytest

from jaxdc.dcp.env import DCP


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        (dict(grid_size=1), ValueError, "grid_size"),
        (dict(grid_size=2.5), TypeError, "grid_size"),
        (dict(total_reward=0), ValueError, "total_reward"),
        (dict(total_reward=1.5), TypeError, "total_reward"),
        (dict(start="corner"), ValueError, "start"),
        (dict(energy_metric="joules"), ValueError, "energy_metric"),
        (dict(item_order="random"), ValueError, "item_order"),
        (dict(total_reward=5, min_total_reward=6), ValueError, "min_total_reward"),
        (dict(min_total_reward=0), ValueError, "min_total_reward"),
        (dict(min_total_reward=2.0), TypeError, "min_total_reward"),
        (dict(item_tilt=1.0), ValueError, "item_tilt=1 tilts the draw of the item count"),
        (dict(min_total_reward=1, item_tilt=9.0), ValueError, "item_tilt must be >= -8 and <= 8, got 9"),
        (dict(min_total_reward=1, item_tilt=float("nan")), ValueError, "item_tilt must be >= -8 and <= 8, got NaN"),
        (dict(min_total_reward=1, item_tilt="1"), TypeError, "item_tilt must be a number"),
        (dict(items_on_base="no"), TypeError, "items_on_base must be a bool (True or False), got 'no'"),
        (dict(idle_terminates=1), TypeError, "idle_terminates must be a bool"),
    ],
)
def test_bad_constructor_args(kwargs, exc, word):
    with pytest.raises(exc) as e:
        DCP(**kwargs)
    assert word in str(e.value)


@pytest.mark.parametrize(
    "kwargs, exc, word",
    [
        (dict(risk="extreme"), ValueError, "risk"),
        (dict(risk=np.zeros((5, 5))), ValueError, "grid_size"),
        (dict(energy=(-1.0, 5.0)), ValueError, "energy"),
        (dict(energy=(0.0, 5.0)), ValueError, "energy"),
        (dict(energy=(9.0, 8.0)), ValueError, "energy"),
        (dict(energy=(float("nan"), 8.0)), ValueError, "energy"),
        (dict(energy=5.0), TypeError, "energy"),
        (dict(max_steps=0), ValueError, "max_steps"),
        (dict(max_steps=2.5), ValueError, "max_steps"),
    ],
)
def test_bad_make_params(kwargs, exc, word):
    with pytest.raises(exc) as e:
        DCP(grid_size=8).make_params(**kwargs)
    assert word in str(e.value)


def test_env_equality_and_defaults():
    assert DCP(grid_size=4) == DCP(grid_size=4) and hash(DCP(grid_size=4)) == hash(DCP(grid_size=4))
    assert DCP(grid_size=4) != DCP(grid_size=5)
    assert DCP(grid_size=4) != DCP(grid_size=4, min_total_reward=1)
    p = DCP().default_params
    assert p.risk.shape == (8, 8) and float(p.init_energy) == 8.0 and float(p.max_energy) == 16.0
    assert DCP().num_actions == 9
