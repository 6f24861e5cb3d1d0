"""Reading delimited text tables (CSV / TSV / semicolons) with line numbers, and parsing their cells.

The quirks of real exports are handled here, once for every table format: a byte-order
mark (UTF-8 or UTF-16), CRLF or CR line endings, blank lines before the header, the
delimiter (sniffed from the header line), trailing delimiters, decimal commas (in files
whose delimiter is not a comma) and a last row cut off mid-write.
"""

from __future__ import annotations

import codecs
import csv
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaze.errors import GazeError
from gaze.trace.columns import TIME_UNITS, split_unit

#: Why a row is not read: the last line has fewer cells than the header and no line break.
CUT_OFF = "last row cut off"
#: Cells read as True / False by ``Table.bools``.
TRUE_WORDS = frozenset({"true", "1", "1.0", "yes"})
FALSE_WORDS = frozenset({"false", "0", "0.0", "no"})


@dataclass(frozen=True)
class Table:
    """A header and its data rows, each with its 1-based line number in the file.

    ``skipped`` counts rows the parser dropped, by reason (``CUT_OFF``).
    """

    path: str
    header: list[str]
    rows: list[list[str]]
    lines: np.ndarray
    delimiter: str = ","
    skipped: Mapping[str, int] = field(default_factory=dict)

    def column(self, name: str) -> int:
        """Index of the column ``name`` (exact after stripping); ``GazeError`` when absent."""
        for i, label in enumerate(self.header):
            if label == name:
                return i
        raise GazeError(self.path, f"missing column {name!r}; columns are {self.header}")

    def find(self, name: str, unit: str | None = None) -> int | None:
        """Index of the first column whose name without its unit suffix is ``name`` (lower case),
        and whose unit is ``unit`` when one is given (case-insensitive); None when there is none."""
        for i, label in enumerate(self.header):
            base, suffix = split_unit(label)
            if base == name and (unit is None or (suffix or "").lower() == unit.lower()):
                return i
        return None

    def require(self, name: str, unit: str | None = None) -> int:
        """Like ``find``, but a missing column is a ``GazeError`` naming it."""
        index = self.find(name, unit)
        if index is None:
            label = name if unit is None else f"{name} ({unit})"
            raise GazeError(self.path, f"missing column {label!r}; columns are {self.header}")
        return index

    def cells(self, index: int) -> list[str]:
        """The stripped cells of one column (empty string where a row is short)."""
        return [row[index].strip() if index < len(row) else "" for row in self.rows]

    def _number_error(self, k: int, index: int, cell: str, what: str = "a number") -> GazeError:
        return GazeError(self.path, f"line {int(self.lines[k])}: column {self.header[index]!r} is not {what}: {cell!r}")

    def floats(self, index: int) -> np.ndarray:
        """One column as floats; empty cells become NaN; a non-numeric cell is a ``GazeError``.

        A decimal comma is accepted when the delimiter is not a comma.
        """
        comma = self.delimiter != ","
        out = np.full(len(self.rows), np.nan)
        for k, cell in enumerate(self.cells(index)):
            if not cell:
                continue
            try:
                out[k] = float(cell.replace(",", ".") if comma else cell)
            except ValueError:
                raise self._number_error(k, index, cell) from None
        return out

    def times(self, index: int, unit: str) -> np.ndarray:
        """A timestamp column in seconds, from values in ``unit`` (a key of ``TIME_UNITS``).

        Nanoseconds are parsed as int64 (they do not fit a float) and re-based to the first
        value before the conversion; other units are read as numbers.  Empty cells are NaN.
        """
        if unit != "ns":
            return self.floats(index) * TIME_UNITS[unit]
        ns = np.zeros(len(self.rows), dtype=np.int64)
        present = np.zeros(len(self.rows), dtype=bool)
        for k, cell in enumerate(self.cells(index)):
            if not cell:
                continue
            try:
                ns[k] = int(cell)
            except ValueError:
                raise self._number_error(k, index, cell, "an integer number of nanoseconds") from None
            present[k] = True
        origin = ns[np.argmax(present)] if present.any() else 0
        return np.where(present, (ns - origin).astype(np.float64) * 1e-9, np.nan)

    def bools(self, index: int, empty: bool) -> np.ndarray:
        """One column of True/False (1/0, yes/no) cells; an empty cell is ``empty``;
        anything else is a ``GazeError`` naming the line."""
        out = np.full(len(self.rows), empty, dtype=bool)
        for k, cell in enumerate(self.cells(index)):
            word = cell.lower()
            if word in TRUE_WORDS:
                out[k] = True
            elif word in FALSE_WORDS:
                out[k] = False
            elif word:
                raise GazeError(
                    self.path, f"line {int(self.lines[k])}: {self.header[index]} must be True or False, got {cell!r}"
                )
        return out


def open_text(path: str | Path) -> str:
    """Read a text file: UTF-8 (a byte-order mark is dropped), or UTF-16 with its byte-order mark.

    ``GazeError`` when the file is missing, unreadable, not text, or empty.
    """
    path = Path(path)
    if not path.exists():
        raise GazeError(str(path), "trace file not found")
    if not path.is_file():
        raise GazeError(str(path), "not a file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise GazeError(str(path), f"cannot read the file: {exc.strerror or exc}") from None
    utf16 = raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE))
    try:
        text = raw.decode("utf-16" if utf16 else "utf-8-sig")
    except UnicodeDecodeError as exc:
        raise GazeError(str(path), f"not a {'UTF-16' if utf16 else 'UTF-8'} text file ({exc.reason})") from None
    if "\0" in text:
        raise GazeError(str(path), "not a text file (it holds NUL bytes)")
    if not text.strip():
        raise GazeError(str(path), "the file is empty")
    return text


def first_line(text: str) -> str:
    """The first line of ``text`` that is not blank."""
    return next(line for line in text.splitlines() if line.strip())


def sniff_delimiter(line: str) -> str:
    """The delimiter of a table whose header line is ``line``: a tab if it has one, else a
    semicolon if it has one, else a comma."""
    if "\t" in line:
        return "\t"
    return ";" if ";" in line else ","


def header_cells(row: list[str]) -> list[str]:
    """A header row's stripped labels, without the empty cells that trailing delimiters leave."""
    cells = [cell.strip() for cell in row]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def parse_table(path: str | Path, text: str, delimiter: str) -> Table:
    """Parse the delimited ``text`` of file ``path`` into a ``Table``; blank lines are skipped.

    A last line without a line break that has fewer cells than the header was cut off
    mid-write: it is dropped and counted in ``Table.skipped``.
    """
    reader = csv.reader(text.splitlines(), delimiter=delimiter)
    header: list[str] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            if header is None:
                header = header_cells(row)
                continue
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        raise GazeError(str(path), f"line {reader.line_num}: {exc}") from None
    if header is None:
        raise GazeError(str(path), "the file has no header line")
    skipped: dict[str, int] = {}
    if rows and not text.endswith(("\n", "\r")) and len(rows[-1]) < len(header):
        rows.pop()
        lines.pop()
        skipped[CUT_OFF] = 1
    return Table(str(path), header, rows, np.asarray(lines, dtype=int), delimiter, skipped)


def read_table(path: str | Path, delimiter: str) -> Table:
    """Read and parse a delimited file into a ``Table`` (see ``parse_table``)."""
    return parse_table(path, open_text(path), delimiter)
