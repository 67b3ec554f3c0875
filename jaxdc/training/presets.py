"""The named training configurations: the recipes of the shipped networks, as typed records of settings fields.

A :class:`Preset` holds the fields a recipe sets (the names of
:class:`~jaxdc.training.dcp.DCPSettings`, :class:`~jaxdc.training.dcg.DCGSettings`,
their algorithm config and the run's ``eval_every``); a field left ``None``
takes the command line's default. ``train.dcp --config NAME`` /
``train.dcg --config NAME`` start from one (the command line turns its
fields into parser defaults, so flags given override them), and
``train.ship`` (:mod:`jaxdc.training.ship`) trains them: one source for both.
:meth:`Preset.flags` renders a preset as the flags recorded in the shipped
metadata's ``"command"``.

The DCP's shipped networks (section 4.5) are trained with the thesis'
hyper-parameters, in the setting of the table each fills (the ENN of Table
4.3 also plays Tables 4.6 and 4.8; Tables 4.4, 4.5 and 4.7 have their own
ENNs; the linear learner and EQN are trained in the setting of Table 4.3).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from jaxdc.training.fields import flags as render_flags


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named configuration: its problem, what it trains (the tables or figures it fills) and the settings fields
    it sets (``None``: not set). The field order is the order of the rendered flags."""

    problem: str  # "dcp" or "dcg"
    description: str
    net: str
    risk: str | None = None
    total_reward: int | None = None
    energy: tuple[float, float] | float | None = None
    min_total_reward: int | None = None
    observation: str | None = None
    risk_maps: str | None = None
    map_seeds: tuple[int, int] | None = None
    energy_range: tuple[float, float] | None = None
    energy_tilt: float | None = None
    item_tilt: float | None = None
    body_features: tuple[int, ...] | None = None
    body_hidden: int | None = None
    body_pool: str | None = None
    heuristic_rows: int | None = None
    grid_sizes: tuple[int, ...] | None = None
    total_steps: int | None = None
    num_envs: int | None = None
    t_max: int | None = None
    lr: float | None = None
    clip_eps: float | None = None
    epochs: int | None = None
    minibatches: int | None = None
    gae_lambda: float | None = None
    normalize_advantages: bool | None = None
    reset_slots: int | None = None
    eval_every: int | None = None
    eval_episodes: int | None = None
    greedy_eval: bool | None = None
    reward_area: int | None = None
    min_reward_area: int | None = None
    collectors: int | None = None
    algo: str | None = None
    mask: str | None = None
    init_from: str | None = None
    #: the seed the shipped file was trained with, where it is not the given one (train.ship's ``--seed``, 0): not
    #: a setting of the recipe, so ``--config`` leaves the seed to the command line
    seed: int | None = None

    def fields(self) -> dict[str, Any]:
        """``{field: value}`` of the settings the preset sets, in order."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if f.name not in ("problem", "description", "seed") and getattr(self, f.name) is not None}

    def flags(self) -> list[str]:
        """The preset as ``train.<problem>`` flags (``--net enn --risk high --energy 8 16 ...``)."""
        return render_flags(self.fields().items())


def _dcp(description: str, net: str, risk: str = "high", energy: tuple[float, float] = (8.0, 16.0),
         **fields: Any) -> Preset:
    return Preset("dcp", description, net, risk=risk, energy=energy, **fields)


#: The shipped DCP networks of the thesis (``jaxdc/assets/dcp``): name -> its preset (the tables it fills).
SHIPPED = {
    "enn": _dcp("4.3, 4.6, 4.8", "enn"),
    "enn_medium": _dcp("4.4", "enn", risk="medium"),
    "enn_low": _dcp("4.5", "enn", risk="low"),
    "enn_energy16_32": _dcp("4.7", "enn", energy=(16.0, 32.0)),
    "linear": _dcp("4.9", "linear"),
    "eqn": _dcp("4.10", "eqn"),
}
#: Beyond the thesis, shipped: the best learners of the two goals of docs/learning.md. ``enn_long``: the
#: faithful A2C in Table 4.3's setting, trained 16M steps instead of 1M (goal: >= 10% above the thesis' ENN
#: reward). ``enn_single_item``: the best single-item learner (goal: >= 97% of the exact optimum of Table
#: 4.8's setting, ``jaxdc/dcp/optimal.py``); the thesis reuses the Table 4.3 ENN there, this one is trained on
#: the single-item setting itself and evaluated greedily (``eval.dcp --greedy``). ``enn_mix``: one ENN at the
#: thesis' 1M steps for Tables 4.3, 4.6 and 4.8, trained on episodes of 1..30 units (``min_total_reward=1``)
#: with Adam at 3e-4 (docs/learning.md, "At the thesis' 1M steps").
BEYOND = {
    "enn_long": _dcp("4.3 (beyond the thesis: 16M steps)", "enn", total_steps=16_000_000, eval_every=2_000_000,
                     eval_episodes=2000),
    "enn_single_item": _dcp("4.8 (beyond the thesis: trained on one item)", "enn", total_reward=1,
                            total_steps=4_000_000, eval_every=1_000_000, eval_episodes=2000, greedy_eval=True),
    "enn_mix": _dcp("4.3, 4.6, 4.8 (beyond the thesis: 1..30 units per training episode, lr 3e-4)", "enn",
                    min_total_reward=1, lr=3e-4, eval_episodes=2000),
}
#: The PPO-style options of ``train.dcp`` (docs/learning.md, "The PPO-style option at 1M steps"), the same
#: options for every table: the best learners at the thesis' 1M steps.
PPO: dict[str, Any] = {"num_envs": 32, "t_max": 32, "lr": 3e-4, "clip_eps": 0.2, "epochs": 4, "minibatches": 4,
       "gae_lambda": 0.95, "normalize_advantages": True, "reset_slots": 4, "eval_every": 1_000_000,
       "eval_episodes": 4000}
BEYOND.update({  # the setting of the faithful ENN of the same tables, then the PPO options
    "enn_ppo": _dcp("4.3, 4.6 (beyond the thesis: the PPO-style option)", "enn", **PPO),
    "enn_ppo_low": _dcp("4.5 (beyond the thesis: the PPO-style option)", "enn", risk="low", **PPO),
    "enn_ppo_energy16_32": _dcp("4.7 (beyond the thesis: the PPO-style option)", "enn", energy=(16.0, 32.0), **PPO),
    "enn_ppo_mix": _dcp("4.3, 4.6, 4.8 (beyond the thesis: the PPO-style option, 1..30 units per training episode)",
                        "enn", min_total_reward=1, **PPO),
    # One network for every map and budget (docs/generalisation.md): each training episode draws its risk map from
    # the first 1,024 maps of the 'mix' generator (never a held-out seed) and its maximum energy from 8..48
    # (initial: half), and the network reads the general observation (risk map and budget planes).
    "enn_general": _dcp("every map and budget (beyond the thesis: per-episode maps and budgets, the general "
                        "observation, the PPO-style option, 4M steps)", "enn", min_total_reward=1,
                        observation="general", risk_maps="mix", map_seeds=(0, 1024), energy_range=(8.0, 48.0),
                        **{**PPO, "total_steps": 4_000_000, "eval_every": 500_000, "eval_episodes": 2000}),
})
# The same recipe with the small budgets weighted (docs/generalisation.md, "The small budgets weighted"): each
# episode's maximum energy drawn with density E**-1 on 8..48 (log-uniform: 8 in 6.5% of the episodes, 48 in 1.1%,
# against 2.4% each uniformly), from scratch, seed 0.
BEYOND["enn_general_tilt"] = dataclasses.replace(
    BEYOND["enn_general"], energy_tilt=1.0,
    description="every map and budget (beyond the thesis: enn_general's recipe with the small budgets weighted, "
                "energy_tilt 1)")
# The same recipe with Safe-Budget's eleventh heuristic row (docs/generalisation.md, "Safe-Budget"): the route to
# LPG's item that the energy allows, beside the ten rows of section 4.4.3; from scratch, seed 0.
BEYOND["enn_general_budget"] = dataclasses.replace(
    BEYOND["enn_general_tilt"], heuristic_rows=11,
    description="every map and budget (beyond the thesis: enn_general_tilt's recipe with Safe-Budget's eleventh "
                "heuristic row)")
# The same recipe with a pooled body (docs/generalisation.md, "Other grid sizes"): each filter's mean and maximum
# over the cells instead of the flattened grid, so one network plays every grid size; from scratch, seed 0.
BEYOND["enn_general_pool"] = dataclasses.replace(
    BEYOND["enn_general_budget"], body_pool="mean_max",
    description="every map, budget and grid size (beyond the thesis: enn_general_budget's recipe with a body "
                "pooled over the cells)")
# enn_general_pool trained on over three grid sizes at once (docs/generalisation.md, "Several grid sizes"): the 48
# environments split 16 / 16 / 16 over 6x6, 8x8 and 10x10, each size drawing its maps from the same generator and
# seeds; 2M more steps from the shipped enn_general_pool at lr 1e-4, seed 1 (6M in all).
BEYOND["enn_general_sizes"] = dataclasses.replace(
    BEYOND["enn_general_pool"], grid_sizes=(6, 8, 10), num_envs=48, lr=1e-4, total_steps=2_000_000,
    init_from="enn_general_pool", seed=1,
    description="every map, budget and grid size (beyond the thesis: enn_general_pool trained on over 6x6, 8x8 "
                "and 10x10 at once)")
#: The strong DCG collectors (docs/dcg.md, "Strong collectors"; beyond the thesis): the PPO-style options at
#: lr 1e-3, 3M steps (``NET_strong``) and the same recipe at the thesis' 1M steps (``NET_strong_1m``, Fig. 5.6).
DCG_STRONG_RECIPE: dict[str, Any] = {**PPO, "lr": 1e-3, "eval_episodes": 2000}
#: The strong DCG collectors: ``NET_strong`` (3M steps) and ``NET_strong_1m`` (1M) for each network, then
#: ``omn_conn_strong_areas``.
DCG_STRONG = {f"{net}_strong{tag}": Preset("dcg", figures, net, total_steps=steps, **DCG_STRONG_RECIPE)
              for net in ("vnn", "imnn", "emnn", "omn_conn")
              for tag, steps, figures in (("", 3_000_000, "5.11, 5.16 (beyond the thesis: the strong recipe, 3M)"),
                                          ("_1m", 1_000_000, "5.6 (beyond the thesis: the strong recipe, 1M)"))}
#: One OMN+CoNN for every reward-area size (Fig. 5.11; beyond the thesis): the recipe for 5M steps on one item in
#: a square whose size each episode draws from 1..4 (``min_reward_area``).
DCG_STRONG["omn_conn_strong_areas"] = Preset(
    "dcg", "5.11 (beyond the thesis: one network for reward-area sizes 1-4)", "omn_conn", total_steps=5_000_000,
    **DCG_STRONG_RECIPE, reward_area=4, min_reward_area=1)
#: One OMN+CoNN for every maximum energy 8..25 (the thesis' open problem; docs/generalisation.md, beyond the
#: thesis): the strong recipe for 5M steps on episodes that each draw their maximum energy from 8..25, read through
#: the general observation (the budget plane, energies over ``ENERGY_SCALE``). Shipped (5M steps).
DCG_GENERAL = {"omn_conn_general": Preset(
    "dcg", "5.8, 5.9 (beyond the thesis: one network for maximum energies 8-25, the general observation)",
    "omn_conn", observation="general", energy_range=(8.0, 25.0), total_steps=5_000_000, **DCG_STRONG_RECIPE)}
#: ``omn_conn_general`` trained on (docs/generalisation.md, "Continued training"; beyond the thesis): started from the
#: shipped ``omn_conn_general`` and trained 10M more steps of the same distribution at lr 3e-4 (15M in all).
DCG_GENERAL["omn_conn_general_long"] = Preset(
    "dcg", "5.8, 5.9 (beyond the thesis: omn_conn_general trained 10M more steps at lr 3e-4)", "omn_conn",
    observation="general", energy_range=(8.0, 25.0), total_steps=10_000_000,
    **{**DCG_STRONG_RECIPE, "lr": 3e-4, "eval_every": 1_000_000}, init_from="omn_conn_general")
#: ``omn_conn_general_long`` trained on with the low budgets weighted (docs/generalisation.md, "A tilted draw"; beyond
#: the thesis): 5M more steps of energies 8..25 drawn with ``energy_tilt`` 2 (P(E) ~ E**-2: energy 8 in 16% of the
#: episodes, 25 in 1.8%) at lr 2e-4, seed 4 (20M in all).
DCG_GENERAL["omn_conn_general_tilt"] = Preset(
    "dcg", "5.8, 5.9 (beyond the thesis: omn_conn_general_long trained 5M more steps, the low budgets weighted)",
    "omn_conn", observation="general", energy_range=(8.0, 25.0), energy_tilt=2.0, total_steps=5_000_000,
    **{**DCG_STRONG_RECIPE, "lr": 2e-4, "eval_every": 1_000_000}, init_from="omn_conn_general_long")
#: ``omn_conn_general_tilt`` trained on under the action mask ``reach_base_or_item`` (docs/generalisation.md,
#: "Training under the mask"; beyond the thesis): 4M more steps of the tilted draw at lr 2e-4, seed 5 (24M in all).
DCG_GENERAL["omn_conn_general_masked"] = Preset(
    "dcg", "5.8, 5.9 (beyond the thesis: omn_conn_general_tilt trained 4M more steps under the mask "
    "reach_base_or_item)", "omn_conn", observation="general", energy_range=(8.0, 25.0), energy_tilt=2.0,
    total_steps=4_000_000, **{**DCG_STRONG_RECIPE, "lr": 2e-4, "eval_every": 1_000_000}, mask="reach_base_or_item",
    init_from="omn_conn_general_tilt")
#: ``omn_conn_general_masked`` trained on with the low budgets weighted harder (docs/generalisation.md, "A harder tilt";
#: beyond the thesis): 8M more steps under its mask, energy_tilt 3 (energy 8 in 23% of the episodes, 25 in 0.9%),
#: lr 1e-4, seed 6.
DCG_GENERAL["omn_conn_general_tilt3"] = dataclasses.replace(
    DCG_GENERAL["omn_conn_general_masked"],
    description="5.8, 5.9 (beyond the thesis: omn_conn_general_masked trained 8M more steps under its mask, the low "
                "budgets weighted by energy_tilt 3)", energy_tilt=3.0, total_steps=8_000_000, lr=1e-4,
    init_from="omn_conn_general_masked", seed=6)
#: ``omn_conn_general_tilt3`` trained on with the low budgets weighted harder still (docs/generalisation.md, "A harder
#: tilt still"; beyond the thesis): 6M more steps under its mask, energy_tilt 4 (energy 8 in 31% of the episodes, 25
#: in 0.4%), lr 1e-4, seed 7.
DCG_GENERAL["omn_conn_general_tilt4"] = dataclasses.replace(
    DCG_GENERAL["omn_conn_general_tilt3"],
    description="5.8, 5.9 (beyond the thesis: omn_conn_general_tilt3 trained 6M more steps under its mask, the low "
                "budgets weighted by energy_tilt 4)", energy_tilt=4.0, total_steps=6_000_000, lr=1e-4,
    init_from="omn_conn_general_tilt3", seed=7)
#: The two-collector team (issue 29; the team game the thesis' conclusion to chapter 5 proposes, beyond the thesis):
#: OMN+CoNN shared by two collectors on the team reward, started from ``omn_conn_strong`` (the team starts as two
#: copies of it: :func:`jaxdc.training.dcg.start_params`) and trained with the strong recipe at lr 3e-4 for 5M steps.
DCG_TEAM = {"team2": Preset(
    "dcg", "the team game, two collectors (beyond the thesis: started from omn_conn_strong)", "omn_conn",
    total_steps=5_000_000, **{**DCG_STRONG_RECIPE, "lr": 3e-4}, collectors=2, init_from="omn_conn_strong")}
#: ``team2`` with a centralised critic (MAPPO, issue 29; docs/dcg.md, "A centralised critic"): the same start, recipe
#: and budget, the value from :class:`~jaxdc.nets.critic.WorldCritic` on the world state.
DCG_TEAM["team2_mappo"] = dataclasses.replace(
    DCG_TEAM["team2"], algo="mappo",
    description="the team game, two collectors, a centralised critic (beyond the thesis: team2's recipe with MAPPO)")
#: The shipped DCP presets (exported by ``train.ship``).
ALL = {**SHIPPED, **BEYOND}
#: Every named configuration.
EVERY = {**ALL, **DCG_STRONG, **DCG_GENERAL, **DCG_TEAM}


def names(problem: str) -> list[str]:
    """The names of ``problem``'s configurations."""
    return [n for n, p in EVERY.items() if p.problem == problem]


def listing(problem: str) -> str:
    """One line per named configuration of ``problem``: its name and what it trains."""
    return "\n".join(f"{n:22s} {EVERY[n].description}" for n in names(problem))
