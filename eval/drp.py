"""``python -m eval.drp``: see :mod:`jaxdc.cli.eval_drp`."""
import sys

from jaxdc.cli.eval_drp import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main())
