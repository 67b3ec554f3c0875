"""jaxdc.pretrained: a parameter file round-trips and refuses the wrong network or a damaged file."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc import pretrained
from jaxdc.nets import make_net


def test_roundtrip_and_checks(tmp_path):
    net = make_net("linear")
    params = net.init(jax.random.PRNGKey(0), jnp.zeros((1, 4, 4, 2)), jnp.zeros((1, 1, 9)))
    path = pretrained.save(tmp_path / "lin", params, {"net": "linear", "problem": "dcp", "grid_size": 4})
    got, meta = pretrained.load(path, net="linear", problem="dcp")
    assert meta["grid_size"] == 4
    for a, b in zip(jax.tree_util.tree_leaves(params), jax.tree_util.tree_leaves(got)):
        np.testing.assert_array_equal(np.asarray(a), b)
    x = jnp.ones((2, 4, 4, 2))
    np.testing.assert_allclose(net.apply(got, x, None)[0], net.apply(params, x, None)[0])
    with pytest.raises(ValueError, match="net='linear', expected 'enn'"):
        pretrained.load(path, net="enn")
    with open(path, "wb") as f:
        f.write(b"\x00garbage")
    with pytest.raises(ValueError, match="unreadable"):
        pretrained.load(path)
    with pytest.raises(ValueError, match="not found"):
        pretrained.load(tmp_path / "missing")
    with pytest.raises(ValueError, match="'problem'"):
        pretrained.save(tmp_path / "x", params, {"net": "linear"})
    with pytest.raises(ValueError, match="no shipped dcp parameters named 'nope'"):
        pretrained.shipped("dcp", "nope")


def test_multi_seed_run_folder_gives_the_chosen_seed(tmp_path):
    """A ``train.dcp --seeds 3,7`` checkpoint stacks every array over seeds; ``run_seed`` picks one."""
    from jaxdc import checkpoint
    from jaxdc.dcp import learned

    meta = {"format": 1, "net": "linear", "grid_size": 4, "total_reward": 5, "risk": "high",
            "energy": [8.0, 16.0], "max_steps": 50, "seeds": [3, 7], "algorithm": {"num_envs": 2}}
    one = learned._train_state("linear", meta, "test")
    seed7 = one.replace(params=jax.tree_util.tree_map(lambda x: x + 1.0, one.params))
    stacked = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), one, seed7)
    checkpoint.save(tmp_path / "run" / "checkpoints", 1, stacked, meta)

    got = learned.load(tmp_path / "run", run_seed=7)
    assert got.metadata["seed"] == 7 and "seeds" not in got.metadata and got.metadata["updates"] == 1
    for a, b in zip(jax.tree_util.tree_leaves(seed7.params), jax.tree_util.tree_leaves(got.params)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    with pytest.raises(ValueError, match=r"seeds \[3, 7\].*got None"):
        learned.load(tmp_path / "run")
    with pytest.raises(ValueError, match=r"seeds \[3, 7\].*got 5"):
        learned.load(tmp_path / "run", run_seed=5)
    exported = pretrained.save(tmp_path / "seed7", got.params, dict(got.metadata))
    assert learned.load(exported, run_seed=7).metadata["seed"] == 7
    with pytest.raises(ValueError, match="seed 7, not of run_seed 3"):
        learned.load(exported, run_seed=3)
