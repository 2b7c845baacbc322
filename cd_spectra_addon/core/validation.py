"""Numbers read from files and forms: one check, one wording, everywhere.

Preset files, set-up sections, the planner's equipment and the model's metadata all hold
numbers that a person may have typed. :func:`check_number` refuses anything but a finite
``int`` or ``float`` (a ``bool`` or a numeric string is not a number here) within the bounds
asked. Its message names the field, says what was expected and shows what was found, e.g.
``disc.pitch_um must be a number > 0, not 'big'``. :func:`check_numbers` does the same for a
fixed-length list (a point, a size, a pair of angles), naming the element that is wrong.

``error`` is the exception to raise, or any callable that turns the message into one, so
each caller keeps its own error type and context (``ValueError`` for files that a loader
wraps, :class:`~.planning.planner.PlanError`, :class:`~.spectrum.model.ModelError`).
A root module of the core: every package may import it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["is_number", "check_number", "check_numbers"]

ErrorFactory = Callable[[str], Exception]


def is_number(value: Any) -> bool:
    """A finite ``int`` or ``float`` (numpy floats included), not a ``bool``."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _expected(integer: bool, above: float | None, at_least: float | None, at_most: float | None, unit: str) -> str:
    kind = "a whole number" if integer else "a number"
    if at_least is not None and at_most is not None:
        return f"{kind} between {at_least:g} and {at_most:g}{unit}"
    bounds = [f"> {above:g}" if above is not None else "", f"≥ {at_least:g}" if at_least is not None else "",
              f"≤ {at_most:g}" if at_most is not None else ""]
    bounds = [b for b in bounds if b]
    if not bounds:
        return ("a whole number" if integer else "a finite number") + unit
    return f"{kind} {' and '.join(bounds)}{unit}"


def check_number(where: str, value: Any, *, above: float | None = None, at_least: float | None = None,
                 at_most: float | None = None, integer: bool = False, unit: str = "",
                 error: ErrorFactory = ValueError) -> float:
    """``value`` as a float if it is a finite number (> ``above``, ≥ ``at_least``, ≤ ``at_most``,
    whole if ``integer``); else ``error(message)`` is raised, the message naming ``where``.
    ``unit`` is appended to the bounds in the message (" degrees")."""
    ok = (is_number(value) and (above is None or value > above) and (at_least is None or value >= at_least)
          and (at_most is None or value <= at_most) and (not integer or float(value).is_integer()))
    if not ok:
        raise error(f"{where} must be {_expected(integer, above, at_least, at_most, unit)}, not {value!r}")
    return float(value)


def check_numbers(where: str, value: Any, count: int, *, names: str = "", above: float | None = None,
                  at_least: float | None = None, at_most: float | None = None, integer: bool = False,
                  unit: str = "", error: ErrorFactory = ValueError) -> tuple[float, ...]:
    """``value`` as a tuple of ``count`` floats if it is a list or tuple of that many numbers,
    each checked as :func:`check_number` does (named ``where[i]``). ``names`` describes the
    elements in the message for a wrong shape (``"[x, y, z]"``)."""
    if not isinstance(value, (list, tuple)) or len(value) != count:
        label = f" {names}" if names else ""
        raise error(f"{where} needs {count} numbers{label}, not {value!r}")
    items: Sequence[Any] = value
    return tuple(check_number(f"{where}[{i}]", v, above=above, at_least=at_least, at_most=at_most,
                              integer=integer, unit=unit, error=error) for i, v in enumerate(items))
