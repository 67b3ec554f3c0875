"""The metadata format of training runs and parameter files, and the one upgrade of older files.

A run's metadata (its ``config.json`` and the metadata of each checkpoint,
:mod:`jaxdc.training.dcp`, :mod:`jaxdc.training.dcg`) and a parameter file's
JSON sidecar (:func:`jaxdc.pretrained.save`) carry ``"format"``:

* format 1 (files without ``"format"`` are format 1): optional settings were
  left out when unset (``min_total_reward``; ``reward_area``,
  ``min_reward_area``), the learner options beside Algorithm 10 were left out
  of an A2C run's ``algorithm`` at their defaults, and an n-step Q run's
  ``algorithm`` held A2C's loss weights, which it does not use;
* format 2 (:data:`FORMAT`): every optional setting is written (``null`` when
  unset) and ``algorithm`` holds exactly the fields of the config that trained
  (``A2CConfig`` or ``QConfig``).

:func:`upgrade` turns any older metadata into the current format; it is the
only place that knows the old ones. Readers call it on load, so a file of any
format reads the same.
"""

from __future__ import annotations

import dataclasses

#: The format written now.
FORMAT = 2
#: Optional settings of each problem, written as ``None`` when unset (format 2).
OPTIONAL_SETTINGS = {"dcp": ("min_total_reward",), "dcg": ("reward_area", "min_reward_area")}
#: Networks trained by n-step Q-learning (``QConfig``); the others by A2C (``A2CConfig``).
Q_NETS = ("eqn",)
#: Networks of the DCP (section 4.5); a run's metadata without ``"problem"`` is a DCP run if its net is one.
DCP_NETS = ("enn", "linear", "cnn", "eqn")


def algorithm_fields(net: str) -> dict:
    """``{field: default}`` of the config that trains ``net`` (``QConfig`` for EQN, else ``A2CConfig``)."""
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.agents.nstep_q import QConfig

    cls = QConfig if net in Q_NETS else A2CConfig
    return {f.name: f.default for f in dataclasses.fields(cls)}


def upgrade(meta: dict) -> dict:
    """``meta`` (of any format) in the current format :data:`FORMAT`; a ``ValueError`` for a newer one."""
    meta = dict(meta)
    version = meta.get("format", 1)
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= FORMAT:
        raise ValueError(f"metadata format {version!r} is not one this jaxdc reads (1..{FORMAT}); "
                         "was the file written by a newer jaxdc?")
    if version == 1:
        problem = meta.get("problem", "dcp" if meta.get("net") in DCP_NETS else "dcg")
        for key in OPTIONAL_SETTINGS.get(problem, ()):
            meta.setdefault(key, None)
        if isinstance(meta.get("algorithm"), dict):
            fields = algorithm_fields(meta.get("net"))
            meta["algorithm"] = {**fields, **{k: v for k, v in meta["algorithm"].items() if k in fields}}
    meta["format"] = FORMAT
    return meta
