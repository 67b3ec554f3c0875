"""``python -m eval.dcg``: see :mod:`jaxdc.cli.eval_dcg`."""

import os
import sys

try:
    from jaxdc.cli.eval_dcg import PROG, build_parser, main  # noqa: F401
except KeyboardInterrupt:  # Ctrl-C while the modules load: the same one line and status as later
    if __name__ != "__main__":
        raise
    print("python -m eval.dcg: interrupted", file=sys.stderr)
    sys.exit(130)

if __name__ == "__main__":
    status = main()
    if status in (130, 143):  # interrupted: skip the interpreter's teardown, which may crash under a running XLA call
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)
