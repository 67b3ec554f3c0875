"""No training run may name a held-out map seed (the generalisation benchmark's test maps)."""

import pytest

from jaxdc import pretrained
from jaxdc.core import generators
from jaxdc.training import presets
from jaxdc.training.instances import HELD_OUT


def _seed_set(fields):
    start, count = fields.get("map_seeds") or (0, 1024)
    return generators.SeedSet(int(start), int(count))


@pytest.mark.parametrize("name", sorted(n for n, p in presets.EVERY.items() if p.problem == "dcp"))
def test_no_preset_trains_on_a_held_out_map(name):
    fields = presets.EVERY[name].fields()
    if fields.get("risk_maps") is not None:
        assert not _seed_set(fields).overlaps(HELD_OUT)


def test_no_shipped_network_was_trained_on_a_held_out_map():
    for name in pretrained.shipped_names("dcp"):
        meta = pretrained.read_metadata(pretrained.shipped("dcp", name))
        if meta.get("risk_maps") is not None:
            assert not _seed_set(meta).overlaps(HELD_OUT), name


def test_settings_refuse_held_out_seeds():
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.training.dcp import DCPSettings

    DCPSettings(net="enn", config=A2CConfig(), risk_maps="mix", map_seeds=(0, 64))
    with pytest.raises(ValueError, match="overlap the held-out test seeds"):
        DCPSettings(net="enn", config=A2CConfig(), risk_maps="mix", map_seeds=(HELD_OUT.start - 10, 20))
    with pytest.raises(ValueError, match="risk_maps must be one of"):
        DCPSettings(net="enn", config=A2CConfig(), risk_maps="nope")
    with pytest.raises(ValueError, match="energy_range: low"):
        DCPSettings(net="enn", config=A2CConfig(), energy_range=(20.0, 10.0))
    with pytest.raises(ValueError, match="observation must be one of"):
        DCPSettings(net="enn", config=A2CConfig(), observation="pixels")
    with pytest.raises(ValueError, match="energy_tilt=2 tilts the draw of energy_range and needs it"):
        DCPSettings(net="enn", config=A2CConfig(), energy_tilt=2.0)
    with pytest.raises(ValueError, match="energy_tilt must be >= -8"):
        DCPSettings(net="enn", config=A2CConfig(), energy_range=(8.0, 48.0), energy_tilt=10.0)


def test_a_tilt_reaches_the_params_and_the_metadata_only_when_set():
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.dcp.env import DCP
    from jaxdc.training.dcp import DCPSettings, run_metadata, settings_from_metadata
    from jaxdc.training.instances import training_params

    tilted = DCPSettings(net="enn", config=A2CConfig(), risk_maps="mix", map_seeds=(0, 4), energy_range=(8.0, 48.0),
                         energy_tilt=1.5)
    meta = run_metadata(tilted, [0])
    assert meta["energy_tilt"] == 1.5
    assert settings_from_metadata(meta, "config.json")[0] == tilted  # --config reproduces it
    assert float(training_params(tilted, DCP()).energy_tilt) == 1.5
    plain = DCPSettings(net="enn", config=A2CConfig(), risk_maps="mix", map_seeds=(0, 4), energy_range=(8.0, 48.0))
    assert "energy_tilt" not in run_metadata(plain, [0])  # old files unchanged
    assert training_params(plain, DCP()).energy_tilt is None


def test_an_item_tilt_reaches_the_environment_and_the_metadata_only_when_set():
    """``item_tilt`` (beyond the thesis) needs ``min_total_reward``; it is recorded only when set (old files
    unchanged), and ``--config`` reproduces it."""
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.training.dcp import DCPSettings, run_metadata, settings_from_metadata

    with pytest.raises(ValueError, match="item_tilt=1 tilts the draw of min_total_reward and needs it"):
        DCPSettings(net="enn", config=A2CConfig(), item_tilt=1.0)
    with pytest.raises(ValueError, match="item_tilt must be >= -8"):
        DCPSettings(net="enn", config=A2CConfig(), min_total_reward=1, item_tilt=-9.0)
    tilted = DCPSettings(net="enn", config=A2CConfig(), min_total_reward=1, item_tilt=0.5)
    meta = run_metadata(tilted, [0])
    assert meta["item_tilt"] == 0.5
    assert settings_from_metadata(meta, "config.json")[0] == tilted
    assert "item_tilt" not in run_metadata(DCPSettings(net="enn", config=A2CConfig(), min_total_reward=1), [0])


def test_settings_refuse_bad_heuristic_rows_by_name():
    from jaxdc.agents.a2c import A2CConfig
    from jaxdc.training.dcp import DCPSettings

    for bad in (True, 12, 10.0):
        with pytest.raises(ValueError, match=r"heuristic_rows \(the number of ENN heuristics\) must be one of"):
            DCPSettings(net="enn", config=A2CConfig(), heuristic_rows=bad)
