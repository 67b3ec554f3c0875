"""Adapters from the functional jaxdc environments to other APIs."""

from jaxdc.wrappers.gymnasium import (
    JaxToGymnasium,
    JaxVectorEnv,
    make_dcg,
    make_dcg_vector,
    make_dcp,
    make_dcp_vector,
)

__all__ = ["JaxToGymnasium", "JaxVectorEnv", "make_dcg", "make_dcg_vector", "make_dcp", "make_dcp_vector"]
