"""``python -m eval.dcp``: see :mod:`jaxdc.cli.eval_dcp`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.eval_dcp", "python -m eval.dcp")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.eval_dcp import PROG, build_parser, main  # noqa: F401
