"""``python -m train.ship``: see :mod:`jaxdc.cli.train_ship`."""

if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("jaxdc.cli.train_ship", "python -m train.ship")  # a Ctrl-C while the libraries load also exits 130
else:
    from jaxdc.cli.train_ship import build_parser, main  # noqa: F401
