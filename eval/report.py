"""``python -m eval.report``: see :mod:`jaxdc.cli.eval_report`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.eval_report", "python -m eval.report")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.eval_report import PROG, build_parser, main  # noqa: F401
