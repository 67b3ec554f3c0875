"""The Data-collecting Robot Problem (thesis chapter 3): graph worlds, tour builders, clustering, plans."""

from jaxdc.drp.nc_clustering import nc
from jaxdc.drp.pgc_clustering import pgc
from jaxdc.drp.solve import CLUSTERINGS, graph_arrays, solve_instances
from jaxdc.drp.tours import BUILDERS, build_tour
from jaxdc.drp.world import Graph, expected_reward, generate, tour_gain, tour_reward

__all__ = ["Graph", "generate", "expected_reward", "tour_gain", "tour_reward", "BUILDERS", "build_tour",
           "CLUSTERINGS", "nc", "pgc", "graph_arrays", "solve_instances"]
