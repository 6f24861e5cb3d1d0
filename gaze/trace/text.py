"""A trace file as the readers see it: its text, its first line (what detection judges) and,
for table formats, its parsed table."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from gaze.trace.columns import split_unit
from gaze.trace.table import Table, first_line, header_cells, parse_table, sniff_delimiter


@dataclass
class TraceText:
    """The decoded text of the trace file at ``path``."""

    path: str
    text: str

    @cached_property
    def first_line(self) -> str:
        """The first line that is not blank."""
        return first_line(self.text)

    @cached_property
    def delimiter(self) -> str:
        """The table delimiter sniffed from the first line."""
        return sniff_delimiter(self.first_line)

    @cached_property
    def labels(self) -> list[str]:
        """The first line's cells, as a table header (stripped, trailing empty cells dropped)."""
        return header_cells(next(csv.reader([self.first_line], delimiter=self.delimiter)))

    @cached_property
    def names(self) -> frozenset[str]:
        """The header's column names without their unit suffixes, lower case."""
        return frozenset(split_unit(label)[0] for label in self.labels)

    @property
    def sibling_dir(self) -> Path:
        """The folder the file lies in (where exports put their metadata files)."""
        return Path(self.path).parent

    @cached_property
    def table(self) -> Table:
        """The text parsed as a table with the sniffed delimiter."""
        return parse_table(self.path, self.text, self.delimiter)

    def table_skipped(self) -> dict[str, int]:
        """The rows the table parser dropped, by reason (nothing when no table was parsed)."""
        return dict(self.__dict__["table"].skipped) if "table" in self.__dict__ else {}
