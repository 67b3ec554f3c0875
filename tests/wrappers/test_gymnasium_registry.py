"""``gymnasium.utils.env_checker.check_env`` passes for every environment id jaxdc registers.

The per-environment tests (``test_gymnasium.py``, ``test_gymnasium_dcg.py``) check their
own ids with several settings; this one walks the registry, so an id added later is
checked without a new test.
"""

from __future__ import annotations

import warnings

import gymnasium
import pytest
from gymnasium.utils.env_checker import check_env

import jaxdc  # noqa: F401  (registers the ids)

IDS = sorted(i for i in gymnasium.registry if i.startswith("jaxdc/"))


def test_the_known_ids_are_registered():
    assert {"jaxdc/DCP-v0", "jaxdc/DCG-v0"} <= set(IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_every_registered_id(env_id):
    env = gymnasium.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the "infinite bound" advisories
        check_env(env.unwrapped)
    vec = gymnasium.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (2,) + env.observation_space.shape and vec.observation_space.contains(obs)
    obs, *_ = vec.step(vec.action_space.sample())
    assert vec.observation_space.contains(obs)
