"""One evaluation of a trained DCG collector as the section-5.5 statistics, with the exact bound where it applies.

:func:`evaluate` plays a :class:`jaxdc.dcg.learned.Learned` collector in the
game it was trained in, with the given changes (energy, strategy set, reward
area, step cap), and returns one JSON-able dict: the statistics of
:func:`jaxdc.dcg.evaluate.summarize` plus the network, its source and the game.
In a reward-area game (Figs. 5.10-5.12) it adds the exact full-information
bound of :mod:`jaxdc.dcg.exact.one_item` and each reward as a fraction of it;
:class:`ExactBounds` solves that bound once per game for a caller that
evaluates many networks in the same game.
"""

from __future__ import annotations

import os
import time

import jax

from jaxdc.dcg.evaluate import evaluate_network, summarize
from jaxdc.dcg.exact.one_item import full_information_bound
from jaxdc.io import unlimited_to_json


def fraction(reward, bound):
    """``reward / bound``; ``None`` when either is undefined (``None``) or the bound is not positive."""
    return None if reward is None or bound is None or not bound > 0 else reward / bound


class ExactBounds:
    """The exact full-information bounds of reward-area games, each solved once per instance."""

    def __init__(self):
        self._solved = {}

    def __call__(self, env, params) -> dict:
        """:func:`jaxdc.dcg.exact.one_item.full_information_bound` of ``env`` with ``params``."""
        key = (env, float(params.max_energy), int(params.max_steps), int(params.chase_tie))
        if key not in self._solved:
            self._solved[key] = full_information_bound(env, params)
        return self._solved[key]


def evaluate(learned, *, episodes, seed, energy=None, strategies=None, reward_area=None, max_steps=None,
             greedy=False, rpe_zero="exclude", bound=True, bounds: ExactBounds | None = None,
             mask: str | None = None) -> dict:
    """The section-5.5 statistics of ``learned`` in its game with the given changes, as one JSON-able dict.

    ``None`` keeps a setting as trained. Unlimited energy is recorded as ``"inf"``
    (:func:`jaxdc.io.unlimited_to_json`); an undefined statistic is ``None`` with its reason. With
    ``reward_area`` and ``bound``, the exact bound of that game (from ``bounds`` when given, solved before any
    game is played) and each reward's fraction of it are added. ``mask`` (beyond the thesis,
    :data:`jaxdc.core.masks.MASKS`; ``None``: the one it was trained under) plays the collector under an action
    mask, recorded when not ``"none"``.
    """
    mask = learned.mask if mask is None else mask
    env, params = learned.game(energy=energy, strategies=strategies, reward_area=reward_area, max_steps=max_steps)
    # the bound first: a game it cannot solve (too big for the memory) is refused before any game is played
    b = (bounds or ExactBounds())(env, params) if reward_area is not None and bound else None
    t0 = time.perf_counter()
    final = evaluate_network(env, params, learned.net, learned.params, jax.random.PRNGKey(seed), episodes, greedy,
                             mask=mask)
    jax.block_until_ready(final)
    out = summarize(final, env.strategies, rpe_zero)
    out["seconds"] = round(time.perf_counter() - t0, 3)
    out["net"] = learned.net_name
    out["alpha"] = learned.metadata.get("alpha")
    out["source"] = os.path.relpath(learned.source) if os.path.exists(learned.source) else learned.source
    out["setting"] = {"grid_size": env.grid_size, "total_reward": env.total_reward,
                      "energy": unlimited_to_json(float(params.max_energy)), "max_steps": int(params.max_steps),
                      "strategies": list(env.strategies), "reward_area": reward_area,
                      "history": learned.setting()["history"], "trained_steps": learned.steps}
    if params.energy_range is not None:  # a range network in its training range (beyond the thesis)
        out["setting"]["energy_range"] = [float(x) for x in params.energy_range]
    out["seed"], out["greedy"] = seed, bool(greedy)
    if mask != "none":
        out["mask"] = mask
    if b is not None:
        out["bound"] = {"total": b["total"], "per_strategy": b["per_strategy"]}
        out["fraction_of_bound"] = fraction(out["reward"]["mean"], b["total"])
        for name, s in out["per_strategy"].items():
            s["fraction_of_bound"] = fraction(s["reward"]["mean"], b["per_strategy"].get(name))
    return out
