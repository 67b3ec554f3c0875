"""The Data-collecting Robot Problem (thesis chapter 3): graph worlds, tour builders, clustering."""

from jaxdc.drp.world import Graph, expected_reward, generate, tour_gain, tour_reward
from jaxdc.drp.tours import BUILDERS, build_tour
from jaxdc.drp.clustering import CLUSTERINGS, nc, pgc

__all__ = ["Graph", "generate", "expected_reward", "tour_gain", "tour_reward", "BUILDERS", "build_tour",
           "CLUSTERINGS", "nc", "pgc"]
