"""Data parallel and multi-seed training (jaxdc.agents.parallel).

The device count of a process is fixed when JAX starts, so the 2-device run
is a subprocess with ``--xla_force_host_platform_device_count=2``; it is
compared with a 1-device subprocess: same seed and global batch, same
parameters (float tolerance), and the environment states really are split
over the two devices. The two subprocesses run side by side (each is mostly
single-threaded XLA compilation).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest

from jaxdc.agents import a2c, parallel
from jaxdc.agents.a2c import A2CConfig
from jaxdc.dcp.env import DCP
from jaxdc.nets import make_net

ENV = DCP(grid_size=4, total_reward=6)
PARAMS = ENV.make_params("low", (4.0, 8.0), max_steps=30)
CONFIG = A2CConfig(total_steps=8 * 8 * 6, num_envs=8, t_max=8, lr=1e-3, reset_slots=2)

# A tiny CNN run: 6 updates of 8 envs x 8 steps; prints the final parameters and where env_state lives.
SCRIPT = textwrap.dedent("""
    import json, sys
    import jax, numpy as np
    from jaxdc.agents import a2c, parallel
    from tests.agents.test_parallel import CONFIG, ENV, PARAMS
    from jaxdc.nets import make_net
    mesh = parallel.data_mesh()
    t = parallel.parallelize(a2c.make_train(CONFIG, ENV, PARAMS, make_net("cnn")), mesh)
    state = t.init(jax.random.PRNGKey(3))
    for _ in range(CONFIG.num_updates):
        state, m = t.update(state)
    leaves = jax.tree_util.tree_leaves(state.params)
    env_leaf = jax.tree_util.tree_leaves(state.env_state)[0]
    shards = sorted(tuple(s.data.shape) for s in env_leaf.addressable_shards)
    print(json.dumps({"devices": len(jax.devices()), "params": [np.asarray(x).ravel().tolist() for x in leaves],
                      "env_shards": shards, "obs_spec": list(state.obs.sharding.spec),
                      "key_spec": list(state.key.sharding.spec),
                      "loss": float(m["loss"])}))
""")


def _start(devices: int) -> subprocess.Popen:
    env = dict(os.environ, JAX_PLATFORMS="cpu",
               XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return subprocess.Popen([sys.executable, "-c", SCRIPT], env=env, cwd=root, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _result(proc: subprocess.Popen) -> dict:
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr[-3000:]
    return json.loads(stdout.strip().splitlines()[-1])


def test_two_devices_give_the_one_device_result_and_really_shard():
    procs = _start(1), _start(2)  # side by side: each spends most of its time in single-threaded compiles
    try:
        one, two = _result(procs[0]), _result(procs[1])
    finally:  # a timeout or failure of one leaves no orphan behind
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    assert one["devices"] == 1 and two["devices"] == 2
    assert two["env_shards"][0][0] == CONFIG.num_envs // 2 and len(two["env_shards"]) == 2
    assert one["env_shards"][0][0] == CONFIG.num_envs
    assert two["obs_spec"] == ["data"] and two["key_spec"] == []  # env batch split, the rest replicated
    for a, b in zip(one["params"], two["params"]):
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
    # the run did move the parameters (so the comparison is not trivially of two inits)
    init = jax.tree_util.tree_leaves(a2c.make_train(CONFIG, ENV, PARAMS, make_net("cnn")).init(
        jax.random.PRNGKey(3)).params)
    assert max(np.abs(np.asarray(x).ravel() - np.asarray(p)).max() for x, p in zip(init, one["params"])) > 1e-4


def test_vmapped_seeds_equal_single_runs():
    base = a2c.make_train(CONFIG, ENV, PARAMS, make_net("cnn"))
    many = parallel.parallelize(base, num_seeds=3)
    seeds = [0, 1, 5]
    state = many.init(jax.vmap(jax.random.PRNGKey)(np.array(seeds)))
    state, metrics = many.run(state, 3)
    assert metrics["loss"].shape == (3, 3)
    for i, seed in enumerate(seeds):
        single, m1 = base.run(base.init(jax.random.PRNGKey(seed)), 3)
        for a, b in zip(jax.tree_util.tree_leaves(single.params), jax.tree_util.tree_leaves(state.params)):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b[i]), rtol=1e-4, atol=1e-5)
        np.testing.assert_allclose(np.asarray(m1["loss"]), np.asarray(metrics["loss"][i]), rtol=1e-4, atol=1e-5)
    # the seeds are different runs
    p = jax.tree_util.tree_leaves(state.params)[0]
    assert not np.allclose(np.asarray(p[0]), np.asarray(p[1]))


@pytest.mark.parametrize("kwargs, match", [
    ({"num_seeds": 0}, "num_seeds"), ({"num_seeds": True}, "num_seeds"),
])
def test_bad_settings_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        parallel.parallelize(a2c.make_train(CONFIG, ENV, PARAMS, make_net("cnn")), **kwargs)


def test_bad_device_count_and_indivisible_batch_are_refused():
    n = len(jax.devices())
    with pytest.raises(ValueError, match="num_devices"):
        parallel.data_mesh(n + 1)
    with pytest.raises(ValueError, match="num_devices"):
        parallel.data_mesh(0)
    with pytest.raises(ValueError, match=r"num_envs \(7\) must be divisible by the number of devices \(2\)"):
        parallel.check_divisible(7, 2)
    parallel.check_divisible(8, 2)
