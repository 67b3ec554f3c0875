"""Hostile parameter files for jaxdc.pretrained: NaN parameters, non-finite metadata, bad sidecar values, and
shipped names resolved from any working folder.

Every bad value is refused before any work with a non-zero exit and one line naming the flag (or the file and
key), the value and the allowed range, without a traceback; no NaN or Infinity reaches a file or stdout; an
interruption leaves the old files or the complete new set.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc import pretrained
from jaxdc.nets import make_net

# ----------------------------------------------------------------------------- parameter files (API)

def _linear_params():
    net = make_net("linear")
    return net.init(jax.random.PRNGKey(0), jnp.zeros((1, 4, 4, 2)), jnp.zeros((1, 1, 9)))


META = {"net": "linear", "problem": "dcp", "grid_size": 4}


def test_a_parameter_file_holding_nan_is_refused_at_load(tmp_path):
    path = pretrained.save(tmp_path / "lin", _linear_params(), META)
    params, _ = pretrained.load(path)
    bad = jax.tree_util.tree_map(np.array, params)  # writable copies
    first = jax.tree_util.tree_flatten_with_path(bad)[0][0]
    first[1][...] = np.nan
    from flax import serialization
    with open(path, "wb") as f:
        f.write(serialization.msgpack_serialize(bad))
    with pytest.raises(ValueError, match=r"lin\.msgpack.*parameter /params/.* holds NaN"):
        pretrained.load(path)


def test_save_refuses_nan_parameters_and_non_finite_metadata_leaving_no_file(tmp_path):
    params = _linear_params()
    nan = jax.tree_util.tree_map(lambda x: x * jnp.nan, params)
    with pytest.raises(ValueError, match="holds NaN"):
        pretrained.save(tmp_path / "a", nan, META)
    with pytest.raises(ValueError, match="train_eval.reward"):
        pretrained.save(tmp_path / "b", params, dict(META, train_eval={"reward": float("nan")}))
    with pytest.raises(ValueError, match="not JSON-able"):
        pretrained.save(tmp_path / "c", params, dict(META, bad=object()))
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("change, needles", [
    ('"grid_size": NaN', ["lin.msgpack", "NaN"]),
    ('"grid_size": true', ["lin.msgpack", "grid_size"]),
    ('"grid_size": -4', ["lin.msgpack", "grid_size"]),
    ('"energy": [8, "lots"]', ["lin.msgpack", "energy"]),
])
def test_a_bad_sidecar_value_names_the_file_and_the_key(tmp_path, change, needles):
    path = pretrained.save(tmp_path / "lin", _linear_params(), META)
    side = tmp_path / "lin.json"
    side.write_text(side.read_text().replace('"grid_size": 4', change))
    with pytest.raises(ValueError) as e:
        pretrained.load(path)
    for n in needles:
        assert n in str(e.value), str(e.value)


def test_a_shipped_name_resolves_from_any_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert pretrained.resolve("enn", "dcp") == os.path.join(pretrained.ASSETS, "dcp", "enn.msgpack")
    assert pretrained.resolve("enn_ppo", "dcp").endswith(os.path.join("dcp", "enn_ppo.msgpack"))
    assert pretrained.resolve("omn_conn_strong", "dcg").endswith(os.path.join("dcg", "omn_conn_strong.msgpack"))
    from jaxdc.dcp import learned
    assert learned.load("enn").net_name == "enn"
    with pytest.raises(ValueError, match="shipped: .*enn_ppo"):
        pretrained.resolve("no_such_net", "dcp")
    (tmp_path / "enn.msgpack").write_bytes(b"")  # a local file of that name wins over the shipped one
    assert pretrained.resolve("enn", "dcp") == "enn"
