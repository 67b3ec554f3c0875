"""``python -m eval.drp``: see :mod:`jaxdc.cli.eval_drp`."""
import sys

try:
    from jaxdc.cli.eval_drp import build_parser, main  # noqa: F401
except KeyboardInterrupt:  # Ctrl-C while the libraries load: the same one line and status as later
    if __name__ != "__main__":
        raise
    print("python -m eval.drp: interrupted", file=sys.stderr)
    sys.exit(130)

if __name__ == "__main__":
    sys.exit(main())
