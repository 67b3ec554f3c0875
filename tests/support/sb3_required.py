"""The guard of the Stable-Baselines3 tests (marker ``sb3``).

Without the ``bench`` extra (PyTorch, Stable-Baselines3) the tests skip; ``.ci/run`` sets
``JAXDC_REQUIRE_SB3=1``, which turns a missing SB3 into a failure instead of a skip.
"""

import os

import pytest


def require_sb3() -> None:
    """Import SB3 and torch, or skip the calling test module (fail under ``JAXDC_REQUIRE_SB3=1``)."""
    if os.environ.get("JAXDC_REQUIRE_SB3") == "1":
        import stable_baselines3  # noqa: F401
        import torch  # noqa: F401
    else:
        pytest.importorskip("torch")
        pytest.importorskip("stable_baselines3")
