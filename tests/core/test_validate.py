"""jaxdc.core.validate: whole numbers, never bools, with the errors the constructors promise."""

from __future__ import annotations

import numpy as np
import pytest

from jaxdc.core import validate
from jaxdc.core.validate import check_int, check_positive_int, is_int


def test_is_int():
    assert is_int(3) and is_int(np.int32(3)) and is_int(np.int64(-1))
    assert not is_int(True) and not is_int(np.bool_(True)) and not is_int(3.0) and not is_int("3")
    assert is_int(3, numpy=False) and not is_int(np.int64(3), numpy=False) and not is_int(False, numpy=False)


def test_check_int_type_then_range():
    assert check_int("k", np.int16(4), 2) == 4 and type(check_int("k", np.int16(4), 2)) is int
    with pytest.raises(TypeError, match=r"^k must be an int >= 2, got True$"):
        check_int("k", True, 2)
    with pytest.raises(TypeError, match=r"^k must be an int >= 2, got 2\.0$"):
        check_int("k", 2.0, 2)
    with pytest.raises(ValueError, match=r"^k must be >= 2, got 1$"):
        check_int("k", 1, 2)


def test_check_positive_int():
    assert check_positive_int("episodes", np.int64(5)) == 5
    for bad in (0, -1, True, 1.0, None):
        with pytest.raises(ValueError, match=rf"^episodes must be an int >= 1, got {bad!r}$"):
            check_positive_int("episodes", bad)
    assert check_positive_int("n", 2, numpy=False) == 2
    with pytest.raises(ValueError, match="n must be an int >= 1"):
        check_positive_int("n", np.int64(2), numpy=False)


# -- floats and seeds ---------------------------------------------------------------------


@pytest.mark.parametrize("value,error,message", [
    (float("nan"), ValueError, "got NaN"),
    (float("inf"), ValueError, "finite"),
    (-float("inf"), ValueError, "finite"),
    (True, TypeError, "a number"),
    ("3", TypeError, "a number"),
    (-0.5, ValueError, ">= 0"),
    (11.0, ValueError, "<= 10"),
])
def test_check_float_refuses(value, error, message):
    with pytest.raises(error, match=message) as e:
        validate.check_float("alpha", value, 0.0, 10.0)
    assert "alpha" in str(e.value)


def test_check_float_accepts_numpy_and_zero_d_arrays_and_inf_when_allowed():
    assert validate.check_float("x", np.float32(2.5), 0.0) == 2.5
    assert validate.check_float("x", np.array(3), 0.0) == 3.0
    assert validate.check_float("x", float("inf"), 0.0, 5.0, allow_inf=True) == float("inf")
    with pytest.raises(ValueError, match="> 0"):
        validate.check_float("x", 0.0, 0.0, low_open=True)
    with pytest.raises(ValueError, match="float32"):
        validate.check_float("x", 1e300)


def test_check_seed_range_and_int_high():
    assert validate.check_seed("seed", 2**32 - 1) == 2**32 - 1
    for bad in (-1, 2**32, 2**70):
        with pytest.raises(ValueError, match=r"seed must be in \[0, 4294967295\]"):
            validate.check_seed("seed", bad)
    with pytest.raises(ValueError, match=r"max_steps must be in \[1, 5\]"):
        validate.check_int("max_steps", 6, 1, 5)


def test_check_choice_names_the_setting_and_its_choices():
    import pytest

    from jaxdc.core.validate import check_choice

    assert check_choice("base", "corner", ("corner", "centre")) == "corner"
    with pytest.raises(ValueError, match=r"^base must be one of \('corner', 'centre'\), got 'middle'$"):
        check_choice("base", "middle", ("corner", "centre"))
    with pytest.raises(ValueError, match="got \\[1\\]"):  # an unhashable value is refused, not a TypeError
        check_choice("rewards", [1], ["1-9", "4-6", "5"])
