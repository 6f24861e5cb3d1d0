"""Reading delimited text tables (CSV / TSV) with line numbers, and parsing their cells."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaze.errors import GazeError


@dataclass(frozen=True)
class Table:
    """A header and its data rows, each with its 1-based line number in the file."""

    path: str
    header: list[str]
    rows: list[list[str]]
    lines: np.ndarray

    def column(self, name: str) -> int:
        """Index of the column ``name`` (exact after stripping); ``GazeError`` when absent."""
        for i, label in enumerate(self.header):
            if label == name:
                return i
        raise GazeError(self.path, f"missing column {name!r}; columns are {self.header}")

    def cells(self, index: int) -> list[str]:
        """The stripped cells of one column (empty string where a row is short)."""
        return [row[index].strip() if index < len(row) else "" for row in self.rows]

    def floats(self, index: int, decimal_comma: bool = False) -> np.ndarray:
        """One column as floats; empty cells become NaN; a non-numeric cell is a ``GazeError``."""
        out = np.full(len(self.rows), np.nan)
        for k, cell in enumerate(self.cells(index)):
            if not cell:
                continue
            try:
                out[k] = float(cell.replace(",", ".") if decimal_comma else cell)
            except ValueError:
                raise GazeError(
                    self.path, f"line {int(self.lines[k])}: column {self.header[index]!r} is not a number: {cell!r}"
                ) from None
        return out


def open_text(path: str | Path) -> str:
    """Read a UTF-8 text file (a byte-order mark is dropped).

    ``GazeError`` when the file is missing, unreadable, not text, or empty.
    """
    path = Path(path)
    if not path.exists():
        raise GazeError(str(path), "trace file not found")
    if not path.is_file():
        raise GazeError(str(path), "not a file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise GazeError(str(path), f"not a UTF-8 text file ({exc.reason})") from None
    except OSError as exc:
        raise GazeError(str(path), f"cannot read the file: {exc.strerror or exc}") from None
    if "\0" in text:
        raise GazeError(str(path), "not a text file (it holds NUL bytes)")
    if not text.strip():
        raise GazeError(str(path), "the file is empty")
    return text


def parse_table(path: str | Path, text: str, delimiter: str) -> Table:
    """Parse the delimited ``text`` of file ``path`` into a ``Table``; blank lines are skipped."""
    reader = csv.reader(text.splitlines(), delimiter=delimiter)
    header: list[str] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            if header is None:
                header = [cell.strip() for cell in row]
                continue
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        raise GazeError(str(path), f"line {reader.line_num}: {exc}") from None
    if header is None:
        raise GazeError(str(path), "the file has no header line")
    return Table(str(path), header, rows, np.asarray(lines, dtype=int))


def read_table(path: str | Path, delimiter: str) -> Table:
    """Read and parse a delimited file into a ``Table`` (see ``parse_table``)."""
    return parse_table(path, open_text(path), delimiter)
