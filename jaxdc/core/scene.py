"""What a picture of one grid state shows: the record an environment's ``scene`` hook returns.

:meth:`jaxdc.core.env.Environment.scene` turns one unbatched host state into a
:class:`Scene`; the viewer (:func:`jaxdc.viewer.render_frame`) draws any
environment that writes the hook, without knowing which problem it is (the
DCP of section 4.3, the DCG of section 5.3, ...).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Scene:
    """The layers of one frame, as host values (numbers and NumPy arrays, nothing traced).

    Attributes:
      items: ``[N, N]`` item reward per cell (drawn as discs with their values).
      agent: ``[2]`` the agent's ``(row, col)``.
      energy: the agent's energy; ``max_energy`` its maximum (status line).
      reward: the reward collected in this episode; ``step``: steps taken.
      outcome: the name of how the episode ended (``"running"`` while it runs).
      risk: ``[N, N]`` risk map drawn as a colour field, or ``None`` (a white field).
      opponent: ``[2]`` the opponent's ``(row, col)``, or ``None`` (no opponent).
      opponent_hidden: whether the agent cannot see the opponent (drawn faded).
      fog: whether the fog cells (top row and left column, base excluded) are hatched.
      notes: extra parts of the status line (e.g. ``"opponent patrol"``).
      agents: ``[k, 2]`` every agent's cell when there are several (the team DCG), or ``None`` (one agent:
        ``agent``); they are drawn numbered, each in its own colour, ``agent`` being the first.
      agent_energies: ``[k]`` their energies (``None`` with one agent).
      agents_active: ``[k]`` whether each is still active (a disabled one is drawn faded), or ``None``.
      opponents: ``[m, 2]`` every opponent's cell when there are several, or ``None`` (``opponent`` alone).
    """

    items: np.ndarray
    agent: np.ndarray
    energy: Any
    max_energy: Any
    reward: Any
    step: int
    outcome: str
    risk: np.ndarray | None = None
    opponent: np.ndarray | None = None
    opponent_hidden: bool = False
    fog: bool = False
    notes: tuple[str, ...] = field(default_factory=tuple)
    agents: np.ndarray | None = None
    agent_energies: np.ndarray | None = None
    agents_active: np.ndarray | None = None
    opponents: np.ndarray | None = None
