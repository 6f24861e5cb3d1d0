"""Column labels: the name and the unit suffix of a header cell, and the time units.

Real exports write units into their headers in brackets or parentheses
(``Recording timestamp [ms]``, ``timestamp [ns]``, ``GazePointX (ADCSpx)``,
``TIME(2021/06/21 14:26:13.616)``); this is the one place that splits them off.
"""

from __future__ import annotations

import re

from gaze.errors import GazeError

#: Seconds per unit of a timestamp column's header suffix.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9}
_UNIT = re.compile(r"^(?P<name>.*?)\s*(\[(?P<square>[^\]]*)\]|\((?P<round>[^)]*)\))?$")


def split_unit(label: str) -> tuple[str, str | None]:
    """``'Recording timestamp [ms]'`` -> ``('recording timestamp', 'ms')``; ``'GazePointX (ADCSpx)'`` ->
    ``('gazepointx', 'ADCSpx')``.  The name is lower-cased; a label without a suffix has unit None."""
    match = _UNIT.match(label.strip())
    assert match is not None  # the pattern matches every string
    unit = match.group("square") if match.group("square") is not None else match.group("round")
    return match.group("name").strip().lower(), None if unit is None else unit.strip()


def time_unit(where: str, label: str, default: str | None = None) -> str:
    """The time unit (a key of ``TIME_UNITS``) in the header ``label`` of file ``where``.

    A label without a unit takes ``default``; with no default that is a ``GazeError``,
    and so is a unit that is not a time unit.
    """
    name, unit = split_unit(label)
    if unit is None:
        if default is None:
            raise GazeError(where, f"{label.strip()!r} has no unit in its header (e.g. [ms] or [us])")
        return default
    unit = unit.lower()
    if unit not in TIME_UNITS:
        raise GazeError(where, f"unknown timestamp unit [{unit}] in {name!r}; expected one of {sorted(TIME_UNITS)}")
    return unit
