"""Exact yardsticks of the DCP: what an agent that solved the MDP could collect.

* :mod:`jaxdc.dcp.exact.optimal` -- value iteration for the single-item DCP (Table 4.8's setting, section 4.5.4).
"""
