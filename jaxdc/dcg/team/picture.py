"""The team DCG as pictures (outside jit): the text grid and the layers of a drawn frame.

:meth:`jaxdc.dcg.team.env.DCGTeam.render_ansi` and :meth:`~jaxdc.dcg.team.env.DCGTeam.scene` call these,
so the viewer draws every collector (numbered, each in its colour) and every opponent without knowing
the game (the team extension of section 5.3 named in the thesis' conclusion to chapter 5). The fog
cells of section 5.5.7 are hatched when an opponent plays a fog strategy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import numpy as np

from jaxdc.core.scene import Scene
from jaxdc.dcg import opponents as opp_lib

if TYPE_CHECKING:
    from jaxdc.dcg.team.env import DCGTeam


def _names(env: DCGTeam, state: Any) -> list[str]:
    return [env.single.strategies[int(s)] for s in np.asarray(state.strategy)]


def render_ansi(env: DCGTeam, state: Any, params: Any) -> str:
    """Text grid: collectors ``1 .. k`` (``c`` once disabled; the lowest number on a shared cell), ``O`` an
    opponent (``X`` on a collector's cell), ``B`` base, item digits (``*`` above 9), ``.`` empty; one row per
    line, then a status line with every collector's energy and outcome, the team reward and the strategies."""
    state = jax.device_get(state)
    items = np.asarray(state.items)
    cells = [tuple(int(v) for v in p) for p in np.asarray(state.pos)]
    active = np.asarray(state.active)
    opps = {tuple(int(v) for v in p) for p in np.asarray(state.opponent.pos)}
    rows = []
    for r in range(env.grid_size):
        line = []
        for c in range(env.grid_size):
            here = [i for i, cell in enumerate(cells) if cell == (r, c)]
            if here and (r, c) in opps:
                ch = "X"
            elif here:
                ch = str(here[0] + 1) if active[here[0]] else "c"
            elif (r, c) in opps:
                ch = "O"
            elif (r, c) == (0, 0):
                ch = "B"
            elif items[r, c] > 0:
                ch = "*" if items[r, c] > 9 else str(int(round(float(items[r, c]))))
            else:
                ch = "."
            line.append(ch)
        rows.append(" ".join(line))
    who = ", ".join(f"{i + 1}: {float(e):g} {env.outcomes[int(o)]}" for i, (e, o) in
                    enumerate(zip(np.asarray(state.energy), np.asarray(state.collector_outcome))))
    rows.append(f"energy {who} (max {float(env.max_energy_of(state, params)):g}), reward "
                f"{float(state.ep_reward):g}, step {int(state.time)}, opponents {', '.join(_names(env, state))}")
    return "\n".join(rows) + "\n"


def scene(env: DCGTeam, state: Any, params: Any) -> Scene:
    """One unbatched host state as the layers of a frame: items, every collector with its energy (faded once
    disabled), every opponent, and the fog cells when an opponent plays a fog strategy."""
    names = _names(env, state)
    strategies = opp_lib.get_strategies(tuple(dict.fromkeys(names)))
    fog = any(s.name in opp_lib.FOG_STRATEGIES or s.hides_in_fog for s in strategies)
    pos, energy = np.asarray(state.pos), np.asarray(state.energy)
    return Scene(items=np.asarray(state.items), agent=pos[0], energy=energy[0],
                 max_energy=env.max_energy_of(state, params), reward=state.ep_reward, step=int(state.time),
                 outcome=env.outcomes[int(state.outcome)], opponent=np.asarray(state.opponent.pos[0]), fog=fog,
                 notes=(f"opponents {', '.join(names)}",), agents=pos, agent_energies=energy,
                 agents_active=np.asarray(state.active), opponents=np.asarray(state.opponent.pos))
