"""``python -m jaxdc <group> <program> [flags]``: the ``jaxdc`` command (:mod:`jaxdc.cli.main`)."""

from jaxdc.cli.main import console

console()
