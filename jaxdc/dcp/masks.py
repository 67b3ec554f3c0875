"""Action masks for DCP policies (beyond the thesis: an option, never the default; docs/generalisation.md).

The masks themselves are :mod:`jaxdc.core.masks` (the DCP and the DCG share the energy rule); this module builds
them from a :class:`~jaxdc.dcp.env.DCP`. ``"reach_base"``: **the budget still reaches the base** (a move must
leave the energy to get home); ``"reach_base_or_item"``: or to reach an item, or it takes one.
"""

from __future__ import annotations

from jaxdc.core.masks import MASKS, Mask
from jaxdc.core.masks import make_mask as _make_mask
from jaxdc.dcp.env import DCP


def reach_base(env: DCP) -> Mask:
    """The mask "the budget still reaches the base" of ``env`` (:mod:`jaxdc.core.masks`)."""
    mask = _make_mask("reach_base", env.grid_size)
    assert mask is not None
    return mask


def reach_base_or_item(env: DCP) -> Mask:
    """The mask "the budget still reaches the base or an item" of ``env``: :func:`reach_base`, but a move may
    also take an item, or leave the energy to reach one (section 4.3 pays the item before the energy check, so
    a last item is worth the agent)."""
    mask = _make_mask("reach_base_or_item", env.grid_size)
    assert mask is not None
    return mask


def make_mask(name: str, env: DCP) -> Mask | None:
    """The mask called ``name`` (one of :data:`jaxdc.core.masks.MASKS`) for ``env``; ``None`` for ``"none"``."""
    return _make_mask(name, env.grid_size)


__all__ = ["MASKS", "Mask", "make_mask", "reach_base", "reach_base_or_item"]
