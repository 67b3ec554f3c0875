"""``python -m train.ship``: see :mod:`jaxdc.cli.train_ship`."""
import sys

from jaxdc.cli.runner import run
from jaxdc.cli.train_ship import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(run(main, "python -m train.ship"))
