"""``python -m eval.report``: see :mod:`jaxdc.cli.eval_report`."""
import sys

from jaxdc.cli.eval_report import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main())
