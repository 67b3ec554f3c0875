"""jaxdc.core.stats: the one percent increase and the one number formatter of the tables and reports."""

import math

from jaxdc.core.stats import format_number, percent_increase


def test_percent_increase_is_the_tables_formula_bit_for_bit():
    for value, baseline in ((23.87, 29.65), (13.16, 11.55), (0.7, 0.83), (1e-9, 3.0)):
        assert percent_increase(value, baseline) == 100.0 * (value - baseline) / baseline
    assert percent_increase(1.0, 0.0) is None and percent_increase(None, 1.0) is None
    assert percent_increase(1.0, None) is None and percent_increase(math.nan, 1.0) is None


def test_format_number_dashes_what_is_undefined():
    assert format_number(0.4567, 3) == "0.457" and format_number(12.0) == "12.00"
    assert format_number(None) == format_number(math.nan) == format_number(math.inf) == "—"
    assert format_number(None, missing="n/a") == "n/a"
    assert format_number(2.5, 1, signed=True, suffix=" pp") == "+2.5 pp" \
        and format_number(-2.5, 1, signed=True) == "-2.5"
