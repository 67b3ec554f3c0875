"""``python -m eval.drp``: see :mod:`jaxdc.cli.eval_drp`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.eval_drp", "python -m eval.drp")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.eval_drp import build_parser, main  # noqa: F401
