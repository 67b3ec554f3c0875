"""A refused number is shown as given (core.validate.value_text), never rounded by ``%g`` into a value that would
pass: the class of messages the reliability probe found (``1.0000001`` shown as ``1``)."""

from __future__ import annotations

import pytest

from jaxdc.cli import eval_dcg
from jaxdc.core.energy import check_energy_range
from jaxdc.core.generators import Bumps, UniformRisk
from jaxdc.dcg.analysis.energies import check_energies
from jaxdc.dcp.env import check_energy
from jaxdc.drp import world

CLOSE = 10.0000001  # %g shows it as 10


@pytest.mark.parametrize("call", [
    lambda: check_energy((CLOSE, 10.0)),
    lambda: check_energy_range((CLOSE, 11.0), 1.0),
    lambda: check_energy_range((11.0, CLOSE), 1.0),
    lambda: check_energies([CLOSE]),
    lambda: world.generate(0, n=3, size=-CLOSE),
], ids=["dcp_energy", "range_low", "range_order", "dcg_energies", "drp_size"])
def test_library_refusals_show_the_value_in_full(call):
    with pytest.raises(ValueError) as e:
        call()
    assert "10.0000001" in str(e.value), str(e.value)


def test_generator_refusals_show_the_values_in_full():
    with pytest.raises(ValueError, match=r"low \(0.30000001\) must not exceed high \(0.3\)"):
        UniformRisk(low=0.30000001, high=0.3)
    with pytest.raises(ValueError, match=r"min_width \(2.50000001\) must not exceed max_width \(2.5\)"):
        Bumps(min_width=2.50000001, max_width=2.5)


def test_the_exact_bound_shows_the_refused_energy_in_full(capsys, tmp_path):
    with pytest.raises(SystemExit):
        eval_dcg.main(["optimum", "--energy", "15.0000001", "--out", str(tmp_path)])
    assert "15.0000001" in capsys.readouterr().err
