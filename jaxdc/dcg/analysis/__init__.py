"""The section-5.5 analysis of the DCG: the thesis' experiments and their claims, and how predictable the
opponent is.

* :mod:`~jaxdc.dcg.analysis.figures` -- the experiments of Figs. 5.6-5.19 and which networks play them.
* :mod:`~jaxdc.dcg.analysis.measures` -- what a claim is made of, and the measures that read the bars.
* :mod:`~jaxdc.dcg.analysis.claims` -- the claims of the thesis' text as records, judged on our bars.
* :mod:`~jaxdc.dcg.analysis.collector_eval` -- one collector's statistics, with the exact bound of a reward area.
* :mod:`~jaxdc.dcg.analysis.experiment` -- every bar of one experiment from a pool of parameter files.
* :mod:`~jaxdc.dcg.analysis.cache` -- stored evaluations, reused for the same file and settings.
* :mod:`~jaxdc.dcg.analysis.report` -- the text, tables and JSON records of the above.
* :mod:`~jaxdc.dcg.analysis.predictability` -- the ceiling of opponent-action prediction (section 5.5.3).
"""
