"""The learned row of a thesis table (section 4.5): which trained network plays it.

Tables 4.3-4.8 have an ENN row, 4.9 the linear learner, 4.10 EQN. The
network is the one trained in the table's risk and energy: the thesis
reuses the ENN of Table 4.3 for Tables 4.6 and 4.8, whose total reward
differs, and Table 4.7 has its own ENN (energy 16/32).
"""

from __future__ import annotations

from jaxdc.dcp import learned as learned_lib


def shipped_learner(spec, grid_size: int | None = None) -> learned_lib.Learned:
    """The shipped learner of table ``spec`` trained in its risk and energy; ``ValueError`` if none is shipped."""
    return learned_lib.shipped(spec.learned[0], spec.risk, spec.energy, grid_size=grid_size)


def check_learner(spec, learned: learned_lib.Learned) -> learned_lib.Learned:
    """``learned`` if it was trained in the risk and energy of table ``spec``, else a ``ValueError`` saying both."""
    net, have = spec.learned[0], learned.setting()
    if have["risk"] != spec.risk or tuple(map(float, have["energy"])) != tuple(map(float, spec.energy)):
        raise ValueError(f"Table {spec.name} needs a {net} trained with risk {spec.risk!r} and energy "
                         f"{spec.energy[0]:g}/{spec.energy[1]:g}; this one was trained with risk "
                         f"{have['risk']!r} and energy {float(have['energy'][0]):g}/{float(have['energy'][1]):g}")
    return learned
