"""The command-line programs of jaxdc.

One module per program (``eval_dcp``, ``eval_dcg``, ``eval_drp``, ``eval_report``,
``train_dcp``, ``train_dcg``, ``train_ship``); each parses its arguments, settles
them once, calls the library and prints or writes. ``python -m eval.dcp`` and
``python -m train.dcg`` at the repository root are thin shims over them.
:mod:`jaxdc.cli.args` holds the argparse value types they share.
"""
