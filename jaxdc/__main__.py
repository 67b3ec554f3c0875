"""``python -m jaxdc <group> <program> [flags]``: the ``jaxdc`` command (:mod:`jaxdc.cli.main`)."""

import sys

from jaxdc.cli.main import main

sys.exit(main())
