"""Exact yardsticks of the DCP: what an agent that solved the MDP could collect.

* :mod:`jaxdc.dcp.exact.optimal` -- value iteration for the single-item DCP (Table 4.8's setting, section 4.5.4).
* :mod:`jaxdc.dcp.exact.unlimited` -- an upper bound on every policy with many items: the best tour over the
  item cells with the energy constraint dropped (beyond the thesis).
"""
