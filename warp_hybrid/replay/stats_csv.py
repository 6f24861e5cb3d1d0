"""The replay's per-frame statistics CSV: one row per frame, every row whole.

Columns, in order: ``FIXED_COLUMNS``, then ``<stage>_ms`` for each stage the caller
names (in its order), then ``RAY_COLUMNS``::

    frame,t,gaze_x,gaze_y,gaze_valid,saccade,window_fraction,traced_fraction,
    frame_ms,budget_ms,within_budget,<stage>_ms...,rays_shadow,rays_reflection,rays_refraction

How each is written: ``frame`` and the ray counts as integers; ``gaze_valid``,
``saccade`` and ``within_budget`` as 0/1; ``t`` (seconds), ``gaze_x``, ``gaze_y``
(normalised, origin top-left), ``window_fraction`` and ``traced_fraction`` (shares of
the screen) with 6 decimals; every ``*_ms`` column with 3 decimals.  Rows end in
``\\n``; nothing is quoted (column names are letters, digits and ``_``).

The file is written under a temporary name beside the target and renamed into place by
``close`` (``partial.PartialFile``); every row is flushed as it is written, and
``close`` cuts the file back to the last whole row, so an interrupted replay whose
``close`` runs in a ``finally:`` leaves a complete CSV of the rows done.
"""

from __future__ import annotations

import csv
import operator
import os
import re
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import WarpHybridError
from .partial import PartialFile


@dataclass(frozen=True)
class _Kind:
    """How a column's values are written and read back."""

    write: Callable[[Any], str]
    read: Callable[[str], Any]


def _write_flag(value: Any) -> str:
    """A boolean (or 0/1) as ``0`` / ``1``."""
    if value is True or value is False or value in (0, 1):
        return "1" if value else "0"
    raise ValueError(f"expected a boolean, got {value!r}")


def _read_flag(text: str) -> bool:
    """``0`` / ``1`` as a boolean."""
    if text not in ("0", "1"):
        raise ValueError(f"expected 0 or 1, got {text!r}")
    return text == "1"


_COUNT = _Kind(lambda v: str(operator.index(v)), int)
_FLAG = _Kind(_write_flag, _read_flag)
_UNIT = _Kind(lambda v: f"{float(v):.6f}", float)  # seconds, normalised gaze, shares of the screen
_MS = _Kind(lambda v: f"{float(v):.3f}", float)

_FIXED = (
    ("frame", _COUNT),
    ("t", _UNIT),
    ("gaze_x", _UNIT),
    ("gaze_y", _UNIT),
    ("gaze_valid", _FLAG),
    ("saccade", _FLAG),
    ("window_fraction", _UNIT),
    ("traced_fraction", _UNIT),
    ("frame_ms", _MS),
    ("budget_ms", _MS),
    ("within_budget", _FLAG),
)
_RAYS = (("rays_shadow", _COUNT), ("rays_reflection", _COUNT), ("rays_refraction", _COUNT))

#: The leading columns of every stats CSV, in order.
FIXED_COLUMNS: tuple[str, ...] = tuple(name for name, _ in _FIXED)
#: The trailing columns: rays traced per type in the frame.
RAY_COLUMNS: tuple[str, ...] = tuple(name for name, _ in _RAYS)

_STAGE_NAME = re.compile(r"[A-Za-z0-9_]+")


def stats_columns(stages: Sequence[str]) -> tuple[str, ...]:
    """The CSV's columns for these stage names: ``FIXED_COLUMNS``, ``<stage>_ms`` per
    stage, ``RAY_COLUMNS``.  Stage names are letters, digits and ``_``, each once."""
    if isinstance(stages, str):
        raise ValueError(f"stages must be a sequence of stage names, got the string {stages!r}")
    for stage in stages:
        if not isinstance(stage, str) or not _STAGE_NAME.fullmatch(stage):
            raise ValueError(f"a stage name must be letters, digits and '_', got {stage!r}")
    columns = FIXED_COLUMNS + tuple(f"{stage}_ms" for stage in stages) + RAY_COLUMNS
    repeated = sorted({c for c in columns if columns.count(c) > 1})
    if repeated:
        raise ValueError(f"stage names give repeated columns: {', '.join(repeated)}")
    return columns


def _kinds(columns: Sequence[str]) -> dict[str, _Kind]:
    """Each column's kind: the fixed and ray columns' own, milliseconds for the stages."""
    known = dict(_FIXED + _RAYS)
    return {column: known.get(column, _MS) for column in columns}


class StatsWriter(AbstractContextManager["StatsWriter"]):
    """Writes the stats CSV at ``path`` (missing folders created) for these stages.

    A context manager (``__exit__`` calls ``close``).  The header is written at once.
    Raises ``WarpHybridError`` naming the file when it cannot be written, ``ValueError``
    for bad stage names.
    """

    def __init__(self, path: str | os.PathLike[str], stages: Sequence[str]) -> None:
        self.path = Path(path)
        self.stages = tuple(stages)
        self.columns = stats_columns(self.stages)
        self.rows = 0
        self._stage_columns = frozenset(f"{stage}_ms" for stage in self.stages)
        self._kinds = _kinds(self.columns)
        self._file = PartialFile(self.path, ".partial.csv")
        try:
            self._out = open(self._file.temp, "wb")  # held open until close
        except OSError as exc:
            self._file.discard()
            raise WarpHybridError(f"{self.path}: cannot write: {exc.strerror or exc}") from None
        self._whole_bytes = 0
        self._closed = False
        self._append(",".join(self.columns))

    def write_row(self, row: Mapping[str, Any]) -> None:
        """Write one frame's row and flush it.  ``row`` maps column names to values; a
        stage column left out is written as 0, any other column left out, or a key
        that is no column, is a ``ValueError`` (nothing is written then)."""
        if self._closed:
            raise WarpHybridError(f"{self.path}: write after close")
        unknown = [key for key in row if key not in self._kinds]
        if unknown:
            raise ValueError(f"{self.path}: unknown stats columns: {', '.join(map(str, unknown))}")
        missing = [c for c in self.columns if c not in row and c not in self._stage_columns]
        if missing:
            raise ValueError(f"{self.path}: row without {', '.join(missing)}")
        cells = []
        for column in self.columns:
            try:
                cells.append(self._kinds[column].write(row.get(column, 0)))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{self.path}: column {column}: {exc}") from None
        self._append(",".join(cells))
        self.rows += 1

    def close(self) -> None:
        """Cut the file back to its last whole row, close it and rename it into place.
        Safe to call again (a no-op)."""
        if self._closed:
            return
        self._closed = True
        try:
            try:
                self._out.flush()
            finally:
                self._out.truncate(self._whole_bytes)
                self._out.close()
        except OSError as exc:
            self._file.discard()
            raise WarpHybridError(f"{self.path}: cannot write: {exc.strerror or exc}") from None
        self._file.commit()

    def __exit__(self, *exc: object) -> None:
        """Close the writer (also after an exception: the rows written are kept)."""
        self.close()

    def _append(self, line: str) -> None:
        """Write one line and flush it; only then does it count as whole."""
        data = (line + "\n").encode("ascii")
        try:
            self._out.write(data)
            self._out.flush()
        except OSError as exc:
            raise WarpHybridError(f"{self.path}: cannot write: {exc.strerror or exc}") from None
        self._whole_bytes += len(data)


def read_stats(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The rows of a stats CSV as dicts in column order: counts as ``int``, flags as
    ``bool``, everything else as ``float``.  Raises ``WarpHybridError`` naming the file
    (and the line) for a missing file, a header that breaks the column contract, or a
    malformed row."""
    path = Path(path)
    try:
        with open(path, newline="", encoding="ascii") as handle:
            lines = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as exc:
        raise WarpHybridError(f"{path}: cannot read the stats CSV: {getattr(exc, 'strerror', None) or exc}") from None
    if not lines:
        raise WarpHybridError(f"{path}: empty stats CSV (no header)")
    header = tuple(lines[0])
    stages = header[len(FIXED_COLUMNS) : len(header) - len(RAY_COLUMNS)]
    if (
        header[: len(FIXED_COLUMNS)] != FIXED_COLUMNS
        or header[len(header) - len(RAY_COLUMNS) :] != RAY_COLUMNS
        or not all(column.endswith("_ms") for column in stages)
    ):
        raise WarpHybridError(f"{path}: not a stats CSV header: {','.join(header)}")
    kinds = _kinds(header)
    rows = []
    for number, cells in enumerate(lines[1:], start=2):
        if len(cells) != len(header):
            raise WarpHybridError(f"{path}: line {number}: {len(cells)} cells, the header has {len(header)}")
        try:
            rows.append({column: kinds[column].read(cell) for column, cell in zip(header, cells)})
        except ValueError as exc:
            raise WarpHybridError(f"{path}: line {number}: {exc}") from None
    return rows
