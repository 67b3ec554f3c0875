"""``python -m train.dcp``: see :mod:`jaxdc.cli.train_dcp`."""
import sys

from jaxdc.cli.runner import run
from jaxdc.cli.train_dcp import Run, build_parser, main  # noqa: F401  (Run: docs/learning.md)

if __name__ == "__main__":
    sys.exit(run(main, "python -m train.dcp"))
