"""The DCP evaluators check the VALUES of the params they are given once, at entry (issue 31): params edited with
``.replace(...)`` (a NaN risk map, an infinite risk, a negative energy) are refused naming ``params.<field>``, the
value and the allowed range, instead of playing silently (a NaN risk map returned no risk losses)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import pytest

from jaxdc.dcp.env import DCP
from jaxdc.dcp.evaluate import evaluate_heuristic, evaluate_learned, evaluate_optimal
from jaxdc.dcp.param_values import check_param_values

ENV = DCP(grid_size=4)
PB = ENV.make_params(risk="high")
KEY = jax.random.PRNGKey(0)


@pytest.mark.parametrize("bad, match", [
    (PB.replace(risk=jnp.full((4, 4), jnp.nan)), r"params\.risk: .*finite numbers in \[0, 1\], got nan"),
    (PB.replace(risk=PB.risk.at[3, 3].set(jnp.inf)), r"params\.risk: .*got inf at cell \(3, 3\)"),
    (PB.replace(max_energy=jnp.float32(0)), r"params\.init_energy/max_energy: maximum energy must be > 0"),
    (PB.replace(max_steps=jnp.int32(0)), r"params\.max_steps: max_steps must be in \[1, 2147483647\], got 0"),
])
def test_the_evaluators_refuse_bad_values(bad, match):
    with pytest.raises(ValueError, match=match):
        evaluate_heuristic(ENV, bad, "safe_both", KEY, 4)
    with pytest.raises(ValueError, match=match):
        evaluate_learned(ENV, bad, None, KEY, 4)
    with pytest.raises(ValueError, match=match):
        evaluate_optimal(DCP(grid_size=4, total_reward=1), bad, KEY, 4)
    with pytest.raises(ValueError, match=match):
        check_param_values(bad)


def test_good_params_still_play():
    assert evaluate_heuristic(ENV, PB, "safe_both", KEY, 4).time.shape == (4,)
    assert check_param_values(PB) is PB
