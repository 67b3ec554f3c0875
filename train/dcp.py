"""``python -m train.dcp``: see :mod:`jaxdc.cli.train_dcp`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.train_dcp", "python -m train.dcp")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.train_dcp import Run, build_parser, main  # noqa: F401  (Run: docs/learning.md)
