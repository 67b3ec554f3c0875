"""One collector over maximum energies (beyond the thesis; the open problem of its conclusion, docs/generalisation.md).

:func:`energy_table` plays a DCG collector -- typically one trained over a range of maximum energies
(``train.dcg --energy-range``) with the general observation -- at each of a list of fixed maximum energies
``E``, and sets beside it, at each ``E``, the full-information bound of the standard game there
(:func:`jaxdc.dcg.exact.many_items.sampled_bound`, as ``eval.dcg optimum --energy E``), the ratio of the two,
and the faithful per-energy collectors of Figs. 5.8-5.9 where they are shipped (``NET`` at energy 15,
``NET_energyE`` at the others). Every network plays the same games (the same key) at a given energy.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import jax

from jaxdc.core.energy import MAX_FINITE_ENERGY
from jaxdc.core.masks import MASKS
from jaxdc.core.validate import check_choice, check_float, value_text
from jaxdc.dcg import learned as learned_lib
from jaxdc.dcg.analysis.collector_eval import evaluate, fraction
from jaxdc.dcg.env import DCG
from jaxdc.dcg.exact.many_items import sampled_bound

#: The thesis' energy of the standard game (section 5.5.1): its faithful collector is ``NET`` itself.
STANDARD_ENERGY = 15.0


def check_energies(energies: Sequence[Any]) -> tuple[float, ...]:
    """Whole maximum energies ``1 .. 2**24`` (the exact bound needs whole budgets), distinct, at least one."""
    if isinstance(energies, (str, bytes)) or not isinstance(energies, Sequence) or not energies:
        raise ValueError(f"energies must be a non-empty list of whole numbers, got {energies!r}")
    out = []
    for e in energies:
        v = check_float("energies", e, 1.0, MAX_FINITE_ENERGY)
        if v != math.floor(v):
            raise ValueError(f"energies must be whole numbers (the exact bound), got {value_text(v)}")
        if v in out:
            raise ValueError(f"energies lists {value_text(v)} twice")
        out.append(v)
    return tuple(out)


def specialist_name(net: str, energy: float) -> str:
    """The faithful per-energy collector of Figs. 5.8-5.9: ``NET`` at energy 15, ``NET_energyE`` otherwise."""
    return net if energy == STANDARD_ENERGY else f"{net}_energy{energy:g}"


def energy_table(learned: learned_lib.Learned, energies: Sequence[Any], *, episodes: int, seed: int,
                 bound_episodes: int, greedy: bool = False, specialists: bool = True,
                 progress: Callable[[str], None] | None = None, mask: str | None = None) -> dict:
    """``{"rows": [...], ...}``: at each energy the network's reward, the full-information bound, their ratio and
    the shipped per-energy collector's reward and ratio (``None`` where none is shipped or ``specialists`` is off).

    The bound is estimated over ``bound_episodes`` games of ``PRNGKey(seed)`` in the standard game of the network's
    grid size, item count and strategies (the setting of ``eval.dcg optimum``). ``mask`` (beyond the thesis,
    :data:`jaxdc.core.masks.MASKS`) plays the network and the specialists under that action mask (``None``: each
    under the one it was trained under); the network's is recorded when not ``"none"``.
    """
    energies = check_energies(energies)
    if mask is not None:
        check_choice("mask", mask, MASKS)
    played = learned.mask if mask is None else mask
    shipped = set(learned_lib.shipped_names()) if specialists else set()
    s = learned.setting()
    rows = []
    for e in energies:
        say = progress or (lambda m: None)
        say(f"energy {e:g}: the network")
        net = evaluate(learned, episodes=episodes, seed=seed, energy=e, greedy=greedy, bound=False, mask=mask)
        say(f"energy {e:g}: the full-information bound over {bound_episodes} games")
        env = DCG(grid_size=s["grid_size"], total_reward=s["total_reward"], strategies=tuple(s["strategies"]),
                  history=1, obs_history=False)
        b = sampled_bound(env, env.make_params(energy=e, max_steps=s["max_steps"], chase_tie=s["chase_tie"]),
                          jax.random.PRNGKey(seed), bound_episodes)
        name = specialist_name(learned.net_name, e)
        spec = None
        if name in shipped:
            say(f"energy {e:g}: the shipped {name}")
            spec = evaluate(learned_lib.shipped(name), episodes=episodes, seed=seed, energy=e, greedy=greedy,
                            bound=False, mask=mask)
        reward = net["reward"]["mean"]
        rows.append({
            "energy": e, "in_range": _in_range(learned, e),
            "reward": {**net["reward"], "se": _se(net)},
            "bound": {"mean": b["mean"], "se": b["se"], "episodes": b["episodes"]},
            "ratio": fraction(reward, b["mean"]),
            "specialist": None if spec is None else {"name": name, "reward": spec["reward"],
                                                     "ratio": fraction(spec["reward"]["mean"], b["mean"])},
        })
    return {"net": learned.net_name, "source": learned.source, "energy_range": learned.metadata.get("energy_range"),
            "observation": learned.metadata.get("observation", "thesis"), "episodes": episodes, "seed": seed,
            "bound_episodes": bound_episodes, "greedy": bool(greedy), **({} if played == "none" else {"mask": played}),
            "rows": rows}


def _se(result: dict) -> float | None:
    sd = result["reward"].get("sd")
    return None if sd is None else sd / math.sqrt(result["episodes"])


def _in_range(learned: learned_lib.Learned, energy: float) -> bool | None:
    r = learned.metadata.get("energy_range")
    return None if r is None else bool(r[0] <= energy <= r[1])


def energy_markdown(table: dict) -> str:
    """The table of :func:`energy_table` as markdown: one row per energy."""
    def cell(x, digits=3):
        return "—" if x is None else f"{x:.{digits}f}"

    lines = [f"Network `{table['net']}` ({table['source']}; trained energies "
             + ("-".join(f"{x:g}" for x in table["energy_range"]) if table["energy_range"] else "fixed")
             + f", {table['observation']} observation), {table['episodes']} games per row, seed {table['seed']}; "
             f"bound over {table['bound_episodes']} games"
             + (", greedy" if table.get("greedy") else "")
             + (f", under the action mask `{table['mask']}`" if table.get("mask") else "") + ".", "",
             "| energy | in range | network | bound | ratio | per-energy collector | its ratio |",
             "|---:|---|---:|---:|---:|---|---:|"]
    for r in table["rows"]:
        spec = r["specialist"]
        inr = "—" if r["in_range"] is None else ("yes" if r["in_range"] else "no")
        lines.append(f"| {r['energy']:g} | {inr} | {cell(r['reward']['mean'])} ± {cell(r['reward']['se'])} | "
                     f"{cell(r['bound']['mean'])} ± {cell(r['bound']['se'])} | {cell(r['ratio'])} | "
                     + ("—" if spec is None else f"`{spec['name']}` {cell(spec['reward']['mean'])}")
                     + f" | {cell(None if spec is None else spec['ratio'])} |")
    return "\n".join(lines) + "\n"
