"""``python -m train.ship``: see :mod:`jaxdc.cli.train_ship`."""
import sys

from jaxdc.cli.train_ship import build_parser, main  # noqa: F401

if __name__ == "__main__":
    sys.exit(main())
