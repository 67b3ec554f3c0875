"""The results page, ``docs/results.md``: the thesis against jaxdc, built from the results folder.

:func:`build_page` assembles it: the DCP tables of chapter 4 (:mod:`jaxdc.report.dcp_tables`,
from the JSON that ``python -m eval.dcp --table`` writes), the hand-written notes, then the
markdown that other commands wrote (:mod:`jaxdc.report.copied`: the DCG figures of chapter 5,
the benchmarks), each with the command that produced it.
"""

from jaxdc.report.page import build_page

__all__ = ["build_page"]
