"""The shipped strong DCG networks (jaxdc.dcg.learned.shipped; docs/dcg.md, "Strong collectors")."""

from __future__ import annotations

import shlex

import jax
import numpy as np
import pytest

from jaxdc.cli import train_dcg
from jaxdc.dcg.evaluate import evaluate_network, summarize
from jaxdc.dcg.learned import shipped, shipped_names

#: The recipe of docs/dcg.md: the PPO-style options at lr 1e-3, 3M steps (``NET_strong``) or 1M (``NET_strong_1m``).
RECIPE = {"num_envs": 32, "t_max": 32, "lr": 1e-3, "clip_eps": 0.2, "epochs": 4,
          "minibatches": 4, "gae_lambda": 0.95, "normalize_advantages": True, "reset_slots": 4}
STRONG = [f"{net}_strong{tag}" for tag in ("", "_1m") for net in ("vnn", "imnn", "emnn", "omn_conn")]


def test_vnn_strong_is_shipped():
    assert "vnn_strong" in shipped_names()


@pytest.mark.parametrize("name", STRONG)
def test_strong_networks_record_the_recipe_and_their_command(name):
    learned = shipped(name)
    algo = learned.metadata["algorithm"]
    assert {k: algo[k] for k in RECIPE} == RECIPE
    assert algo["total_steps"] == (1_000_000 if name.endswith("_1m") else 3_000_000)
    assert learned.metadata["seed"] == 0 and learned.net_name == name.removesuffix("_1m").removesuffix("_strong")
    argv = shlex.split(learned.metadata["command"])[3:]  # after "python -m train.dcg"
    args = train_dcg.build_parser().parse_args(argv)
    assert (args.net, args.seed, args.ship) == (learned.net_name, 0, f"jaxdc/assets/dcg/{name}.msgpack")


def test_vnn_strong_plays_better_than_the_faithful_vnn():
    """On the same 2,000 standard games the strong VNN collects more than the shipped 1M-step VNN by > 4 SE."""
    means = {}
    for name in ("vnn", "vnn_strong"):
        learned = shipped(name)
        env, params = learned.game()
        s = summarize(evaluate_network(env, params, learned.net, learned.params, jax.random.PRNGKey(5), 2000),
                      env.strategies)
        means[name] = (s["reward"]["mean"], s["reward"]["sd"] / np.sqrt(2000))
    (a, se_a), (b, se_b) = means["vnn_strong"], means["vnn"]
    assert a - b > 4 * np.hypot(se_a, se_b), means
