"""``python -m eval.dcp``: see :mod:`jaxdc.cli.eval_dcp`."""
import os
import sys

try:
    from jaxdc.cli.eval_dcp import PROG, build_parser, main  # noqa: F401
    from jaxdc.cli.runner import run
    from jaxdc.dcp.tables import incr_rows  # noqa: F401  (tests/test_learned_policies.py)
except KeyboardInterrupt:  # Ctrl-C while the modules load: the same one line and status as later
    if __name__ != "__main__":
        raise
    print("python -m eval.dcp: interrupted", file=sys.stderr)
    sys.exit(130)

if __name__ == "__main__":
    status = run(main, PROG)
    if status in (130, 143):  # interrupted: skip the interpreter's teardown, which may crash under a running XLA call
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)
