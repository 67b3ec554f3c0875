"""``python -m eval.dcg``: see :mod:`jaxdc.cli.eval_dcg`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.eval_dcg", "python -m eval.dcg")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.eval_dcg import PROG, build_parser, main  # noqa: F401
