"""Test-session set-up (one fresh XLA compile cache) and the fixtures used everywhere (hand-made states:
:mod:`tests.support.states`)."""

from __future__ import annotations

import os
import shutil
import signal
import tempfile

import jax
import pytest

from tests.support.states import make_state

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
    # A shell starts a background job (`cmd &`, nohup) with SIGINT ignored, and the CLIs that the Ctrl-C tests
    # start would inherit that and rightly keep running; the tests need Ctrl-C to reach them as from a terminal.
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
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
