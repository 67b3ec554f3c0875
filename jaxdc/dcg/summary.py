"""The section-5.5 statistics of a set of DCG games as a typed record (Figs. 5.6-5.19).

:func:`jaxdc.dcg.evaluate.summary` computes a :class:`Summary` from played
games: the *episode reward*, the energy used, the *reward per energy* (RPE)
and the steps, each a :class:`MeanSD` over the games (section 5.5.3); the
number of games; how they ended; the opponent-action accuracy of a network
with an opponent-action head; and the same for the games of each opponent
strategy. :meth:`Summary.to_json` is the JSON object the result files store
(an undefined statistic is ``null`` beside its reason, never NaN), and
:meth:`Summary.from_dict` reads one back.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple


class MeanSD(NamedTuple):
    """The mean and (population) SD of one statistic; both ``None`` when it is undefined, with the reason."""

    mean: float | None
    sd: float | None
    undefined: str | None = None  #: why there is no mean (e.g. "no episode consumed energy")

    @classmethod
    def from_dict(cls, d: dict | None) -> MeanSD:
        """The record of ``{"mean", "sd"[, "undefined"]}``; an absent statistic (``None``) is undefined."""
        return cls(None, None) if d is None else cls(d["mean"], d["sd"], d.get("undefined"))

    def to_json(self) -> dict:
        """``{"mean", "sd"}``, with ``"undefined"`` when there is no mean (:func:`jaxdc.core.stats.mean_sd`)."""
        out = {"mean": self.mean, "sd": self.sd}
        if self.undefined is not None:
            out["undefined"] = self.undefined
        return out


@dataclasses.dataclass(frozen=True)
class Summary:
    """The statistics of a set of games (section 5.5.3).

    ``per_strategy`` holds one :class:`Summary` per opponent strategy (in the env's order; their means, weighted
    by ``episodes``, add up to the total); ``None`` in those per-strategy records themselves.
    """

    reward: MeanSD
    energy: MeanSD
    rpe: MeanSD
    episodes: int
    outcomes: dict[str, int]
    steps: MeanSD
    opponent_accuracy: float | None  #: the fraction of predicted steps where the prediction was ``o_t``
    per_strategy: dict[str, Summary] | None = None

    @classmethod
    def from_dict(cls, d: dict) -> Summary:
        """The record of a stored summary (a result file's object, extra keys ignored). Fields that a hand-made
        or partial record lacks are undefined: statistics ``MeanSD(None, None)``, no games, no outcomes."""
        per = d.get("per_strategy")
        return cls(MeanSD.from_dict(d.get("reward")), MeanSD.from_dict(d.get("energy")), MeanSD.from_dict(d.get("rpe")),
                   int(d.get("episodes") or 0), dict(d.get("outcomes") or {}), MeanSD.from_dict(d.get("steps")),
                   d.get("opponent_accuracy"),
                   None if per is None else {name: cls.from_dict(s) for name, s in per.items()})

    def to_json(self) -> dict:
        """The JSON object of :func:`jaxdc.dcg.evaluate.summarize`, key for key and in its order."""
        out = {"reward": self.reward.to_json(), "energy": self.energy.to_json(), "rpe": self.rpe.to_json(),
               "episodes": self.episodes, "outcomes": dict(self.outcomes), "steps": self.steps.to_json(),
               "opponent_accuracy": self.opponent_accuracy}
        if self.per_strategy is not None:
            out["per_strategy"] = {name: s.to_json() for name, s in self.per_strategy.items()}
        return out
