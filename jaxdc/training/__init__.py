"""Training runs of the learners (sections 4.5, 5.5.2): the run loop, its logs and metadata, the DCP and DCG runs.

* :mod:`~jaxdc.training.loop`: :class:`~jaxdc.training.loop.TrainingRun`, the loop of a run (evaluation rows,
  checkpoints, exact resume, NaN stop, several seeds and devices);
* :mod:`~jaxdc.training.metrics`: the metrics CSV and the TensorBoard writer;
* :mod:`~jaxdc.training.dcp`, :mod:`~jaxdc.training.dcg`: the DCP and DCG settings records, the runs built from
  them, a run's metadata and its reading back (``settings_from_metadata``);
* :mod:`~jaxdc.training.fields`: the settings' field names, their command-line spelling and
  :class:`~jaxdc.training.fields.SettingError` (library errors name fields);
* :mod:`~jaxdc.training.presets`: the named configurations (the shipped networks' recipes) as typed records;
* :mod:`~jaxdc.training.ship`: the runs that make the shipped parameter files, and the DCP export.

The metadata format and schema live below the problems, in :mod:`jaxdc.metadata`.

The command lines (``python -m train.dcp`` ...) are :mod:`jaxdc.cli.train_dcp`, :mod:`jaxdc.cli.train_dcg` and
:mod:`jaxdc.cli.train_ship`.
"""
