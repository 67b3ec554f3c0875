"""jaxdc.wrappers.sb3 misuse: ``set_attr`` cannot bypass the grid-shape check or change the fixed attributes
(issue 31)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.support.sb3_required import require_sb3  # noqa: E402

pytestmark = pytest.mark.sb3

require_sb3()

from jaxdc.dcp.env import DCP  # noqa: E402
from jaxdc.wrappers.sb3 import JaxdcVecEnv  # noqa: E402


def _venv():
    return JaxdcVecEnv(DCP(grid_size=6), num_envs=2, seed=0)


def test_set_attr_params_of_another_grid_size_is_refused():
    venv = _venv()
    before = venv.params
    with pytest.raises(ValueError, match="shape"):
        venv.set_attr("params", DCP(grid_size=8).make_params())
    assert venv.params is before


def test_set_attr_params_of_another_kind_is_refused():
    venv = _venv()
    with pytest.raises((TypeError, ValueError), match="params"):
        venv.set_attr("params", {"risk": np.zeros((6, 6))})


def test_set_attr_params_for_some_copies_only_is_refused():
    venv = _venv()
    with pytest.raises(ValueError, match="all 2 copies"):
        venv.set_attr("params", venv.params, indices=[0])


def test_set_attr_same_shape_params_are_taken_and_used():
    venv = _venv()
    params = DCP(grid_size=6).make_params()
    venv.set_attr("params", params)
    assert venv.params is params
    venv.reset()
    venv.step_async(np.zeros(2, np.int64))
    assert venv.step_wait()[0].shape == (2, 6, 6, 2)


@pytest.mark.parametrize("name", JaxdcVecEnv.READ_ONLY)
def test_set_attr_of_fixed_attributes_is_refused(name):
    venv = _venv()
    with pytest.raises(ValueError, match=name):
        venv.set_attr(name, None)


@pytest.mark.parametrize("options", [{"bogus": 1}, [{}, {"risk": "low"}]])
def test_unknown_reset_options_are_refused(options):
    """SB3's set_options stored any key and reset() dropped it silently; the adapter refuses it as the gymnasium
    adapters do (naming the key and the allowed ones), and stores nothing."""
    venv = _venv()
    with pytest.raises(ValueError, match=r"reset options \['(bogus|risk)'\] are not known: .*take none"):
        venv.set_options(options)
    assert venv._options == [{}, {}]
    venv.reset()
    venv.set_options({})  # no option is fine
    venv.set_options(None)
    venv.reset()
    with pytest.raises(TypeError, match=r"options\[1\] must be a dict or None"):
        venv.set_options([{}, "risk"])
    with pytest.raises(ValueError, match="one dict .* per copy, 2, got 1"):
        venv.set_options([{}])
    venv._options = [{"bogus": 1}, {}]  # stored behind set_options' back: refused by reset, before any change
    with pytest.raises(ValueError, match="bogus"):
        venv.reset()


@pytest.mark.parametrize("field, value, match", [
    ("risk", np.inf, r"params\.risk: .*finite numbers in \[0, 1\], got inf at cell \(1, 1\)"),
    ("risk", np.nan, r"params\.risk: .*finite numbers in \[0, 1\], got nan"),
    ("risk", 1.5, r"params\.risk: .*must lie in \[0, 1\]"),
])
def test_set_attr_params_with_bad_values_is_refused(field, value, match):
    import jax.numpy as jnp

    venv = _venv()
    before = venv.params
    with pytest.raises(ValueError, match=match):
        venv.set_attr("params", before.replace(risk=before.risk.at[1, 1].set(value)))
    assert venv.params is before
    with pytest.raises(ValueError, match=r"params\.max_steps: max_steps must be in \[1, 2147483647\], got 0"):
        JaxdcVecEnv(DCP(grid_size=6), 2, before.replace(max_steps=jnp.int32(0)))


def test_step_wait_without_step_async_is_refused():
    """SB3 pairs step_async(actions) with step_wait(): without actions the step is refused by name, and each
    step_async serves one step_wait."""
    venv = _venv()
    venv.reset()
    with pytest.raises(RuntimeError, match="step_async"):
        venv.step_wait()
    venv.step_async(np.zeros(2, np.int64))
    venv.step_wait()
    with pytest.raises(RuntimeError, match="step_async"):
        venv.step_wait()


def test_a_batch_too_large_for_memory_is_refused_before_allocating(monkeypatch):
    monkeypatch.setenv("JAXDC_MEMORY_LIMIT", str(64 * 2**20))
    with pytest.raises(MemoryError, match="num_envs"):
        JaxdcVecEnv(DCP(grid_size=6), num_envs=10**9, seed=0)
