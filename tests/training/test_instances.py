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
