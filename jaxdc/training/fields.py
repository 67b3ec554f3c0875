"""The fields of a training run's settings: their names, their command-line spelling, and errors that name them.

The library names every setting by its field: a field of
:class:`~jaxdc.training.dcp.DCPSettings` / :class:`~jaxdc.training.dcg.DCGSettings`
(``net``, ``risk``, ``energy``, ...), of the algorithm's config
(``A2CConfig``/``QConfig``: ``total_steps``, ``num_envs``, ``lr``, ...) or of
the run's :class:`~jaxdc.training.loop.RunControl` (``eval_every``,
``devices``, ...). :data:`DESTS` is how ``train.dcp``/``train.dcg`` spell the
fields whose flag is not the dashed field name, so the command line and the
commands recorded in shipped metadata (:func:`flags`) come from one table; a
:class:`SettingError` names fields and is rendered with their flags by the
command line (:meth:`SettingError.render`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

#: Field -> the attribute of the parsed command line that sets it, where that is not the field's own name.
DESTS = {"total_steps": "steps", "num_envs": "envs", "entropy_coef": "entropy", "aux_lr": "omn_lr",
         "progress": "no_progress"}


def dest(field: str) -> str:
    """The parsed command line's attribute that sets ``field``."""
    return DESTS.get(field, field)


def flag(field: str) -> str:
    """The command-line flag that sets ``field`` (``"--steps"`` for ``total_steps``, ``"--eval-every"``)."""
    return "--" + dest(field).replace("_", "-")


def number_text(v: float | int) -> str:
    """``v`` as the shortest text that reads back as ``v``: ``8`` (not ``8.0``), ``0.95``, ``3e-4`` (not
    ``0.0003``); a tie keeps the decimal form."""
    if isinstance(v, int):
        return str(v)
    decimal = repr(float(v))
    decimal = decimal[:-2] if decimal.endswith(".0") else decimal
    for digits in range(17):
        text = f"{v:.{digits}e}"
        if float(text) == v:
            break
    mantissa, exponent = text.split("e")
    if "." in mantissa:
        mantissa = mantissa.rstrip("0").rstrip(".")
    scientific = f"{mantissa}e{int(exponent)}"
    return scientific if len(scientific) < len(decimal) else decimal


def flags(fields: Iterable[tuple[str, Any]]) -> list[str]:
    """The command-line words of ``(field, value)`` pairs, in their order: a ``True`` switch is its flag alone,
    ``None`` and ``False`` give nothing, a tuple or list one word per value."""
    out: list[str] = []
    for field, v in fields:
        if v is None or v is False:
            continue
        if v is True:
            out.append(flag(field))
        elif isinstance(v, (tuple, list)):
            out += [flag(field), *(number_text(x) if isinstance(x, (int, float)) else str(x) for x in v)]
        else:
            out += [flag(field), number_text(v) if isinstance(v, (int, float)) else str(v)]
    return out


def _escape(text: object) -> str:
    return str(text).replace("{", "{{").replace("}", "}}")


class SettingError(ValueError):
    """A bad setting: the text names the settings as fields (``eval_every``); a command line shows it with its
    flags (:meth:`render`).

    ``template`` is a ``str.format`` text whose ``{0}``, ``{1}`` ... are the ``fields`` (literal braces
    doubled; :meth:`text` escapes a value).
    """

    def __init__(self, template: str, *fields: str) -> None:
        self.template, self.fields = template, fields
        super().__init__(self.render(lambda f: f))

    @staticmethod
    def text(value: object) -> str:
        """``value`` as text safe inside a template."""
        return _escape(value)

    def render(self, name: Callable[[str], str] = flag) -> str:
        """The message with each field written as ``name(field)`` (default: its command-line flag)."""
        return self.template.format(*(name(f) for f in self.fields))


def check_tilt_has_range(tilt: Any, span: Any, name: str = "energy_tilt", span_name: str = "energy_range") -> float:
    """The checked tilt ``name`` of a run's settings (DCP and DCG alike): a finite power-law tilt of the draw that
    the setting ``span_name`` (value ``span``) spans, ``|tilt| <= MAX_TILT``
    (:func:`jaxdc.core.sampling.power_law_integer`), which must be 0 when ``span`` is ``None``. The defaults are
    the maximum energy's (``energy_tilt``, ``energy_range``); the DCP's item count has ``item_tilt`` and
    ``min_total_reward``."""
    from jaxdc.core.sampling import MAX_TILT
    from jaxdc.core.validate import check_float, value_text

    tilt = check_float(name, tilt, -MAX_TILT, MAX_TILT)
    if tilt != 0.0 and span is None:
        raise SettingError(f"{{0}}={value_text(tilt)} tilts the draw of {{1}} and needs it: without {{1}}, "
                           "{0} must be 0", name, span_name)
    return tilt
