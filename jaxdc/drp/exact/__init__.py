"""Exact yardsticks of the DRP (beyond the thesis).

* :mod:`jaxdc.drp.exact.subset_dp` -- the optimal plan of a small instance (n <= 9) by dynamic programmes over
  subsets of the nodes.
"""
