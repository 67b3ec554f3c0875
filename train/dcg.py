"""``python -m train.dcg``: see :mod:`jaxdc.cli.train_dcg`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.train_dcg", "python -m train.dcg")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.train_dcg import build_parser, main  # noqa: F401
