"""Exact yardsticks of the DCG: what a collector that knew everything could collect.

* :mod:`jaxdc.dcg.exact.machine` -- the opponent as a finite machine and the rules on arrays
  of cells, shared by both searches.
* :mod:`jaxdc.dcg.exact.one_item` -- the one-item game of section 5.5.5 (Fig. 5.10),
  solved for every start state at once: the exact full-information bound of a
  reward area, and plans that reach it.
* :mod:`jaxdc.dcg.exact.many_items` -- the optimum of one sampled many-item game
  (the standard game of 5.5.1), and its mean over sampled games.
* :mod:`jaxdc.dcg.exact.team` -- the optimum of one sampled game for a team of two
  collectors (issue 29), exact where the joint search fits, and a proven upper bound.
"""
