"""Test-session set-up (one fresh XLA compile cache) and shared helpers: hand-made states and risk maps."""

from __future__ import annotations

import os
import shutil
import tempfile

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxdc.dcp.env import RUNNING, EnvState

# ----------------------------------------------------------------------------- one XLA cache per session
#
# Most of the suite's time is XLA compilation, and many tests compile the same program again: fresh jit
# wrappers of one function in this process, the CLI/notebook/sharding subprocesses, the other pytest-xdist
# worker. A persistent compile cache that starts empty for the session and is removed at its end lets
# them share those compiles while the run stays a clean-checkout run: nothing is read from or written to
# the user's ~/.cache (JAXDC_NO_CACHE=1 keeps the CLIs' own cache, jaxdc.io.enable_compilation_cache, off).
# A cache hit loads the executable that the same program compiled to, so results do not change.
# ``--no-xla-cache`` turns it off; JAXDC_TEST_XLA_CACHE=DIR makes the session use (and keep) DIR.

SESSION_CACHE = "JAXDC_TEST_XLA_CACHE"
_OWNED = pytest.StashKey[str]()


def pytest_addoption(parser):
    parser.addoption("--no-xla-cache", action="store_true",
                     help="jaxdc: no session-wide persistent XLA compile cache (every process compiles alone)")


def pytest_configure(config):
    os.environ.setdefault("JAXDC_NO_CACHE", "1")
    if config.getoption("no_xla_cache"):
        return
    path = os.environ.get(SESSION_CACHE)
    if not path:  # the first process of the session (plain pytest, or xdist's controller before its workers)
        path = tempfile.mkdtemp(prefix="jaxdc-test-xla-")
        os.environ[SESSION_CACHE] = path
        config.stash[_OWNED] = path
    # subprocesses (CLIs, notebook kernels, the sharding runs) read these when they import jax
    os.environ["JAX_COMPILATION_CACHE_DIR"] = path
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


def pytest_unconfigure(config):
    path = config.stash.get(_OWNED, None)
    if path:
        shutil.rmtree(path, ignore_errors=True)
        for name in (SESSION_CACHE, "JAX_COMPILATION_CACHE_DIR"):
            if os.environ.get(name) == path:
                del os.environ[name]


def items_grid(n, items):
    """``items``: a dict ``{(row, col): reward}`` or an ``[N, N]`` array."""
    if isinstance(items, dict):
        arr = np.zeros((n, n), np.float32)
        for (r, c), v in items.items():
            arr[r, c] = v
        return arr
    return np.asarray(items, np.float32)


def make_state(env, pos, energy, items, rank=None, time=0, ep_reward=0.0, ep_energy=0):
    """A hand-made :class:`EnvState` of ``env`` (rank: dict {(r, c): rank} or array; default row-major)."""
    n = env.grid_size
    if rank is None:
        rank_arr = np.arange(n * n, dtype=np.int32).reshape(n, n)
    elif isinstance(rank, dict):
        rank_arr = np.full((n, n), 10_000, np.int32)
        for (r, c), v in rank.items():
            rank_arr[r, c] = v
    else:
        rank_arr = np.asarray(rank, np.int32)
    return EnvState(
        pos=jnp.asarray(pos, jnp.int32),
        energy=jnp.float32(energy),
        items=jnp.asarray(items_grid(n, items)),
        time=jnp.int32(time),
        outcome=jnp.int32(RUNNING),
        ep_reward=jnp.float32(ep_reward),
        ep_energy=jnp.int32(ep_energy),
        rank=jnp.asarray(rank_arr),
    )


def risk_with(n, cells=None, fill=0.0):
    """An ``N x N`` risk map of ``fill`` (base 0) with ``cells = {(r, c): risk}`` set."""
    risk = np.full((n, n), fill, np.float32)
    risk[0, 0] = 0.0
    for (r, c), v in (cells or {}).items():
        risk[r, c] = v
    return risk


def make_game(env, pos, opp, strategy, items=None, energy=15.0, home=None, target=None, phase=0):
    """A hand-made DCG state (collector at ``pos``, opponent at ``opp``); shared by the DCG tests."""
    from jaxdc.dcg import EnvState, OpponentState

    n = env.grid_size
    arr = np.zeros((n, n), np.float32)
    for (r, c), v in (items or {}).items():
        arr[r, c] = v
    home = opp if home is None else home
    return EnvState(
        pos=jnp.asarray(pos, jnp.int32), energy=jnp.float32(energy), items=jnp.asarray(arr),
        opponent=OpponentState(pos=jnp.asarray(opp, jnp.int32), home=jnp.asarray(home, jnp.int32),
                               target=jnp.asarray(home if target is None else target, jnp.int32),
                               phase=jnp.int32(phase)),
        strategy=jnp.int32(env.strategies.index(strategy)), history=jnp.zeros((n, n, env.history), jnp.float32),
        time=jnp.int32(0), outcome=jnp.int32(0), ep_reward=jnp.float32(0), ep_energy=jnp.int32(0),
    )


@pytest.fixture
def state_builder():
    return make_state


@pytest.fixture
def read_only_folder(tmp_path, monkeypatch):
    """An empty folder no one may write into (mode 0o500). Root writes anywhere, so under root
    ``os.access`` is also made to answer "not writable" for it, which is what jaxdc's checks ask."""
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        real = os.access
        monkeypatch.setattr(os, "access", lambda p, m, **kw: False if os.fspath(p) == str(ro) else real(p, m, **kw))
    yield ro
    ro.chmod(0o700)
