"""The section-3.5 analysis of the DRP: the figure experiments, their tables and records, and the thesis' claims.

* :mod:`~jaxdc.drp.analysis.experiment` -- the experiment of Figs. 3.1-3.5 and the figures' settings.
* :mod:`~jaxdc.drp.analysis.parallel` -- the experiment over processes, one per core.
* :mod:`~jaxdc.drp.analysis.cache` -- stored experiments, reused for the same settings.
* :mod:`~jaxdc.drp.analysis.summary` -- normalised mean/SD, PGC/NC, CSV and markdown tables.
* :mod:`~jaxdc.drp.analysis.gaps` -- the heuristics against the exact solver.
* :mod:`~jaxdc.drp.analysis.claims` -- section 3.5's claims as data, judged on stored experiments.
"""
