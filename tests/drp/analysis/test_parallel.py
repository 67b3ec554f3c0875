"""The section 3.5 experiment in processes: builder groups, and the same results as in one process."""

import numpy as np

from jaxdc.drp.analysis.experiment import run_experiment
from jaxdc.drp.analysis.parallel import NC_COST, builder_groups, run_parallel
from jaxdc.drp.tours import BUILDERS


def test_builder_groups_cover_every_builder_once_and_balance():
    for workers in (1, 2, 3, 6, 10):
        groups = builder_groups(list(BUILDERS), workers)
        assert len(groups) == min(workers, len(BUILDERS))
        assert sorted(b for g in groups for b in g) == sorted(BUILDERS)
    two = builder_groups(list(BUILDERS), 2)
    loads = sorted(sum(NC_COST[b] for b in g) for g in two)
    assert loads[1] - loads[0] <= max(NC_COST.values()) - min(NC_COST.values())
    assert ["gi"] in [g[:1] for g in two]  # the heaviest builder starts a group


def test_figure_experiment_in_processes_equals_one_process():
    # Two worker processes (builder groups, PGC clusters sent by the parent) give exactly the rewards of the
    # in-process experiment: the rewards are computed from the tours on the host (float64), so neither the
    # compiled programs of another process nor the batches the tours were built in can move them.
    args = ("4-6", 2, 8, [0, 20, 40], "centre", 3)
    want, _ = run_experiment(*args, ["ng", "gi"], ("nc", "pgc"), quiet=True)
    got, timing = run_parallel(2, *args, False, True, builders=["ng", "gi"])
    assert sorted(got) == sorted(want)
    for key in want:
        np.testing.assert_array_equal(got[key], want[key])
    assert (want[("nc", "gi")][:, 1:] > 0).any()  # some robot is sent: the comparison is not vacuous
    assert {"pgc_clustering", "nc_gi", "nc_ng", "pgc_gi", "pgc_ng"} <= set(timing)
