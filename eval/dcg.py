"""``python -m eval.dcg``: see :mod:`jaxdc.cli.eval_dcg`."""

import sys

from jaxdc.cli.eval_dcg import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main())
