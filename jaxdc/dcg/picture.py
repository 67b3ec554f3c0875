"""The DCG as pictures (outside jit): the text grid and the layers of a drawn frame (section 5.3).

:meth:`jaxdc.dcg.env.DCG.render_ansi` and :meth:`jaxdc.dcg.env.DCG.scene` call
these, so that the wrappers and the viewer draw a game without knowing it is one.
The fog cells of section 5.5.7 (row 0 and column 0) are marked for the fog
strategies, and the opponent is shown as hidden while the collector is in the
fog under a fog-hiding strategy (``double_blind``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import jax
import numpy as np

from jaxdc.core.scene import Scene
from jaxdc.dcg import opponents as opp_lib

if TYPE_CHECKING:
    from jaxdc.dcg.env import DCG


def render_ansi(env: DCG, state: Any, params: Any) -> str:
    """Text grid: ``C`` collector, ``O`` opponent (``X`` both on one cell), ``B`` base, item digits
    (``*`` above 9), ``.`` empty; ``~`` marks fog cells while the opponent is hidden from the collector.
    One row per line, then a status line."""
    state = jax.device_get(state)
    items = np.asarray(state.items)
    me = tuple(int(p) for p in state.pos)
    op = tuple(int(p) for p in state.opponent.pos)
    hidden = bool(env.opponent_hidden(state))
    rows = []
    for r in range(env.grid_size):
        cells = []
        for c in range(env.grid_size):
            if (r, c) == me and (r, c) == op:
                ch = "X"
            elif (r, c) == me:
                ch = "C"
            elif (r, c) == op:
                ch = "O"
            elif (r, c) == (0, 0):
                ch = "B"
            elif items[r, c] > 0:
                ch = "*" if items[r, c] > 9 else str(int(round(float(items[r, c]))))
            elif hidden and (r == 0 or c == 0):
                ch = "~"
            else:
                ch = "."
            cells.append(ch)
        rows.append(" ".join(cells))
    energy = float(state.energy)
    rows.append(
        f"energy {energy:g}/{float(env.max_energy_of(state, params)):g}, reward {float(state.ep_reward):g}, "
        f"step {int(state.time)}, opponent {env.strategies[int(state.strategy)]}"
        + (" (hidden)" if hidden else "")
    )
    return "\n".join(rows) + "\n"


def scene(env: DCG, state: Any, params: Any) -> Scene:
    """One unbatched host state as the layers of a frame: items, collector with its energy, opponent (faded
    while hidden), and the fog cells for the strategies of :data:`~jaxdc.dcg.opponents.FOG_STRATEGIES` or a
    fog-hiding one; the status line names the episode's strategy."""
    strategy = opp_lib.get_strategies((env.strategies[int(state.strategy)],))[0]
    return Scene(items=np.asarray(state.items), agent=np.asarray(state.pos), energy=state.energy,
                 max_energy=env.max_energy_of(state, params), reward=state.ep_reward, step=int(state.time),
                 outcome=env.outcomes[int(state.outcome)], opponent=np.asarray(state.opponent.pos),
                 opponent_hidden=bool(strategy.hides_in_fog and opp_lib.in_fog(np.asarray(state.pos))),
                 fog=strategy.name in opp_lib.FOG_STRATEGIES or strategy.hides_in_fog,
                 notes=(f"opponent {strategy.name}",))
