"""``python -m eval.dcp``: see :mod:`jaxdc.cli.eval_dcp`."""
import sys

from jaxdc.cli.eval_dcp import build_parser, main  # noqa: F401
from jaxdc.dcp.tables import incr_rows  # noqa: F401  (tests/test_learned_policies.py)

if __name__ == "__main__":
    sys.exit(main())
