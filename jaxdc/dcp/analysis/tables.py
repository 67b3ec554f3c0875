"""The thesis' DCP experiments (Tables 4.1 and 4.3-4.10): settings and published numbers.

Each :class:`TableSpec` holds the environment setting of one table and the
thesis' rows, ``{policy: (reward avg, reward sd, energy avg, energy sd, rpe avg, rpe sd)}``
(Table 4.1 reports reward only; missing values are ``None``).
:func:`incr_rows` is the tables' "Incr.%" column (:func:`jaxdc.core.stats.percent_increase`) for every
navigator of a table, thesis beside ours.
"""

from __future__ import annotations

import dataclasses
import math

from jaxdc.core.stats import percent_increase

INF = math.inf


@dataclasses.dataclass(frozen=True)
class TableSpec:
    name: str
    caption: str
    risk: str
    total_reward: int
    energy: tuple[float, float]
    rows: dict  # policy -> (r, r_sd, e, e_sd, rpe, rpe_sd)
    learned: tuple[str, ...] = ()  # rows that need a trained network

    @property
    def heuristic_rows(self) -> tuple[str, ...]:
        return tuple(p for p in self.rows if p not in self.learned)


#: The columns of Tables 4.3-4.10 as (summary key, index of the mean in a thesis row).
COLUMNS = (("reward", 0), ("energy", 2), ("rpe", 4))


def incr_rows(spec: TableSpec, rows: dict, learner: str | None) -> dict:
    """``{navigator: {column: [thesis incr.%, ours incr.%]}}``: ``learner``'s increment over each navigator.

    ``rows`` maps policy names to summaries (:func:`jaxdc.dcp.evaluate.summarize`);
    empty when the learner has no row.
    """
    if learner is None or learner not in rows:
        return {}
    out = {}
    for name in spec.heuristic_rows:
        th_l, th_n = spec.rows.get(learner), spec.rows.get(name)
        out[name] = {col: [percent_increase(th_l[i], th_n[i]) if th_l and th_n else None,
                           percent_increase(rows[learner][col]["mean"], rows[name][col]["mean"])]
                     for col, i in COLUMNS}
    return out


_NAV = ("safe_reward", "safe_recharge", "safe_both", "safe_neither")


def _nav_table(name, caption, risk, total, energy, values, learner="enn"):
    rows = dict(zip(_NAV + (learner,), values))
    return TableSpec(name, caption, risk, total, energy, rows, learned=(learner,))


TABLES: dict[str, TableSpec] = {
    "4.1": TableSpec(
        "4.1",
        "Chapter-3 tour heuristics on DCP, infinite energy, high risk, total reward 30",
        "high",
        30,
        (INF, INF),
        {
            "ng": (15.64, 8.51, None, None, None, None),
            "osa": (19.18, 8.80, None, None, None, None),
            "tl": (20.05, 8.58, None, None, None, None),
            "gml": (18.09, 9.02, None, None, None, None),
            "lpg": (20.25, 8.40, None, None, None, None),
        },
    ),
    "4.3": _nav_table("4.3", "High risk, total reward 30, energy 8/16", "high", 30, (8, 16), [
        (11.55, 6.38, 29.65, 19.75, 0.495, 0.301),
        (7.39, 5.33, 12.03, 9.42, 0.691, 0.339),
        (8.51, 5.16, 24.35, 18.27, 0.429, 0.241),
        (8.05, 6.08, 11.05, 9.85, 0.854, 0.341),
        (13.16, 7.17, 23.87, 16.88, 0.685, 0.314),
    ]),
    "4.4": _nav_table("4.4", "Medium risk, total reward 30, energy 8/16", "medium", 30, (8, 16), [
        (13.43, 6.62, 33.14, 19.88, 0.495, 0.266),
        (9.51, 6.95, 17.56, 15.36, 0.625, 0.311),
        (9.08, 5.45, 25.05, 18.58, 0.439, 0.241),
        (12.04, 8.17, 19.16, 16.80, 0.771, 0.312),
        (14.73, 7.51, 24.54, 16.46, 0.715, 0.302),
    ]),
    "4.5": _nav_table("4.5", "Low risk, total reward 30, energy 8/16", "low", 30, (8, 16), [
        (18.08, 8.37, 39.55, 23.23, 0.546, 0.238),
        (13.41, 8.42, 27.58, 21.54, 0.578, 0.269),
        (11.78, 6.82, 29.90, 21.64, 0.478, 0.245),
        (17.88, 9.60, 34.30, 24.83, 0.655, 0.265),
        (19.36, 8.87, 33.98, 18.68, 0.641, 0.250),
    ]),
    "4.6": _nav_table("4.6", "High risk, total reward 15, energy 8/16", "high", 15, (8, 16), [
        (6.42, 3.65, 24.31, 15.80, 0.327, 0.232),
        (4.11, 3.12, 11.05, 8.71, 0.448, 0.314),
        (4.60, 2.96, 19.60, 13.69, 0.265, 0.176),
        (4.78, 3.62, 10.10, 9.49, 0.594, 0.311),
        (7.55, 3.76, 18.66, 12.39, 0.488, 0.235),
    ]),
    "4.7": _nav_table("4.7", "High risk, total reward 30, energy 16/32", "high", 30, (16, 32), [
        (17.66, 9.10, 34.18, 21.14, 0.598, 0.235),
        (10.46, 7.71, 12.66, 10.61, 0.948, 0.312),
        (19.43, 8.71, 41.10, 21.87, 0.536, 0.218),
        (9.73, 7.17, 10.87, 9.31, 1.001, 0.298),
        (19.78, 8.54, 39.07, 20.29, 0.566, 0.229),
    ]),
    "4.8": _nav_table("4.8", "High risk, one item of reward 1, energy 8/16", "high", 1, (8, 16), [
        (0.70, 0.46, 5.80, 4.60, 0.232, 0.308),
        (0.43, 0.50, 5.32, 3.33, 0.164, 0.273),
        (0.45, 0.50, 5.83, 3.33, 0.156, 0.269),
        (0.55, 0.50, 4.78, 3.68, 0.228, 0.317),
        (0.83, 0.37, 6.70, 9.32, 0.272, 0.294),
    ]),
    "4.9": _nav_table("4.9", "Linear learner, setting of Table 4.3", "high", 30, (8, 16), [
        (11.74, 6.36, 30.17, 19.69, 0.491, 0.300),
        (7.41, 5.42, 12.17, 9.64, 0.683, 0.336),
        (8.56, 5.20, 24.52, 18.33, 0.428, 0.248),
        (8.16, 6.12, 11.19, 9.86, 0.852, 0.344),
        (7.39, 4.55, 21.09, 17.18, 0.423, 0.241),
    ], learner="linear"),
    "4.10": _nav_table("4.10", "EQN, setting of Table 4.3", "high", 30, (8, 16), [
        (11.74, 6.45, 30.13, 19.70, 0.484, 0.276),
        (7.45, 5.39, 12.24, 9.69, 0.688, 0.343),
        (8.53, 5.14, 24.46, 18.18, 0.425, 0.241),
        (8.13, 6.16, 11.21, 10.01, 0.851, 0.346),
        (9.04, 4.42, 10.08, 9.21, 1.007, 0.352),
    ], learner="eqn"),
}
