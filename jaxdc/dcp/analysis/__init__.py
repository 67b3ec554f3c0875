"""The chapter-4 analysis of the DCP: the thesis' tables, their rows and results, and the learners that play them.

* :mod:`~jaxdc.dcp.analysis.tables` -- the settings and published numbers of Tables 4.1 and 4.3-4.10; Incr.%.
* :mod:`~jaxdc.dcp.analysis.setting` -- the evaluation setting of a table or a single policy.
* :mod:`~jaxdc.dcp.analysis.rows` -- the rows of a table played alike.
* :mod:`~jaxdc.dcp.analysis.table_learner` -- which shipped learner plays a table's learned row.
* :mod:`~jaxdc.dcp.analysis.best_learner` -- the best shipped jaxdc learner of a table (beyond the thesis).
* :mod:`~jaxdc.dcp.analysis.table_results` -- a table's markdown and JSON.
* :mod:`~jaxdc.dcp.analysis.risk_map` -- risk maps from ``.npy``/``.json`` files.
* :mod:`~jaxdc.dcp.analysis.generalisation` -- a network over maps and budgets it was and was not trained on
  (beyond the thesis).
"""
