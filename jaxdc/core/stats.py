"""Episode statistics shared by the DCP and the DCG evaluations (Tables 4.1-4.10, Figs. 5.6-5.19).

Both problems report the same columns over a batch of finished episodes:
the episode reward, the energy consumed and the reward per energy (RPE),
each as mean and SD, plus how the episodes ended. The final states of both
environments carry ``ep_reward``, ``ep_energy``, ``outcome`` and ``time``,
so one function serves both; each problem passes its own outcome names.
"""

from __future__ import annotations

import math

import numpy as np

from jaxdc.core.validate import check_choice

#: How RPE treats an episode that consumed no energy (footnote 4 of Table 4.3 is silent).
RPE_ZERO = ("exclude", "zero")


def mean_sd(x, empty: str = "no episodes") -> dict:
    """``{"mean", "sd"}`` of a 1-D sample (population SD, ``ddof=0``).

    An empty sample has no mean: ``{"mean": None, "sd": None, "undefined": empty}``
    (``None`` is JSON's ``null``; ``empty`` says why), never NaN.
    """
    x = np.asarray(x, np.float64)
    if x.size == 0:
        return {"mean": None, "sd": None, "undefined": empty}
    return {"mean": float(x.mean()), "sd": float(x.std())}


def reward_per_energy(reward, energy, rpe_zero: str = "exclude") -> np.ndarray:
    """Per-episode ``reward / energy`` (footnote 4 of Table 4.3; the RPE of Figs. 5.7, 5.9, 5.12).

    Episodes that used no energy are left out (``rpe_zero="exclude"``) or
    count as RPE 0 (``"zero"``).
    """
    check_choice("rpe_zero", rpe_zero, RPE_ZERO)
    reward = np.asarray(reward, np.float64)
    energy = np.asarray(energy, np.float64)
    used = energy > 0
    rpe = np.where(used, reward / np.where(used, energy, 1.0), 0.0)
    return rpe[used] if rpe_zero == "exclude" else rpe


def episode_summary(final_states, outcomes, rpe_zero: str = "exclude", mask=None) -> dict:
    """Mean/SD of reward, energy, RPE and steps over finished episodes, plus outcome counts.

    ``final_states`` is a batch of final environment states (``ep_reward``,
    ``ep_energy``, ``outcome``, ``time``), ``outcomes`` the environment's
    outcome names (index = ``outcome``; ``"running"`` is not counted) and
    ``mask`` (optional, boolean ``[episodes]``) selects a subset, e.g. one
    opponent strategy. RPE is the mean of per-episode ``reward / energy``
    (footnote 4: "Reward per energy is also an average over 10,000 runs").
    """
    reward = np.asarray(final_states.ep_reward, np.float64)
    energy = np.asarray(final_states.ep_energy, np.float64)
    outcome = np.asarray(final_states.outcome)
    steps = np.asarray(final_states.time, np.float64)
    if mask is not None:
        mask = np.asarray(mask, bool)
        reward, energy, outcome, steps = reward[mask], energy[mask], outcome[mask], steps[mask]
    return {
        "reward": mean_sd(reward),
        "energy": mean_sd(energy),
        "rpe": mean_sd(reward_per_energy(reward, energy, rpe_zero),
                       "no episode consumed energy" if reward.size else "no episodes"),
        "episodes": int(reward.size),
        "outcomes": {name: int((outcome == i).sum()) for i, name in enumerate(outcomes) if name != "running"},
        "steps": mean_sd(steps),
    }


def percent_increase(value: float | None, baseline: float | None) -> float | None:
    """How much ``value`` exceeds ``baseline``, as a percentage of ``baseline``: ``100 (value - baseline) / baseline``.

    The "Incr.%" of Tables 4.3-4.10 (caption of Table 4.3: "the difference between ENN's reward and
    Safe-Reward's reward as a percentage of Safe-Reward's"), and every other relative gain jaxdc reports.
    ``None`` when either is missing or NaN, or ``baseline`` is 0. (``100 (value / baseline - 1)`` is the same
    number but may differ in the last bit; this form is the one the committed tables were written with.)
    """
    if value is None or baseline is None or baseline == 0 or math.isnan(value) or math.isnan(baseline):
        return None
    return 100.0 * (value - baseline) / baseline


def format_number(x: float | None, digits: int = 2, *, missing: str = "—", signed: bool = False,
                  suffix: str = "") -> str:
    """``x`` with ``digits`` decimals (``signed``: always with its sign) and ``suffix``, as the tables and reports
    print a statistic; ``missing`` for an undefined one (``None``, NaN or infinite).

    >>> format_number(0.4567, 3), format_number(None), format_number(2.5, 1, signed=True, suffix=" pp")
    ('0.457', '—', '+2.5 pp')
    """
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return missing
    return f"{x:{'+' if signed else ''}.{digits}f}{suffix}"
