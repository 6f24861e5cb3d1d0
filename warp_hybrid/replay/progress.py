"""The replay's progress bar on the terminal (tqdm).

Shows the frames done (of the total when known), frames per second and, as a postfix,
the share of frames within budget so far.  It writes to standard output and, unless
told otherwise, only when standard output is a terminal: piped or redirected output
gets no bar at all (the counts are still kept).
"""

from __future__ import annotations

import sys
from contextlib import AbstractContextManager
from typing import TextIO

from tqdm import tqdm


def _is_terminal(stream: TextIO) -> bool:
    """Whether ``stream`` is a terminal (a closed or odd stream is not)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


class Progress(AbstractContextManager["Progress"]):
    """A progress bar over ``total`` items (``None``: unknown, no bar length).

    ``enabled``: ``None`` shows it only when standard output is a terminal; ``True`` or
    ``False`` force it.  ``unit`` names the items; ``budgeted``: show the share within
    budget (frames of a replay; not for the items of other work).  A context manager
    (``__exit__`` calls ``close``).
    """

    def __init__(
        self, total: int | None, enabled: bool | None = None, unit: str = "frame", budgeted: bool = True
    ) -> None:
        stream = sys.stdout
        self.budgeted = budgeted
        self.enabled = _is_terminal(stream) if enabled is None else bool(enabled)
        self.total = total
        self.frames = 0
        self.frames_within_budget = 0
        self._bar: tqdm | None = None
        if self.enabled:
            self._bar = tqdm(total=total, unit=unit, file=stream, dynamic_ncols=True, leave=True)

    @property
    def within_budget_pct(self) -> float | None:
        """Percent of the frames so far that were within budget (``None`` before any)."""
        return None if self.frames == 0 else 100.0 * self.frames_within_budget / self.frames

    def update(self, within_budget: bool = True) -> None:
        """Count one finished item, and whether it was within budget."""
        self.frames += 1
        self.frames_within_budget += bool(within_budget)
        if self._bar is not None:
            if self.budgeted:
                self._bar.set_postfix_str(f"within budget {self.within_budget_pct:.0f}%", refresh=False)
            self._bar.update(1)

    def close(self) -> None:
        """Finish the bar (it stays on the terminal); safe to call again."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __exit__(self, *exc: object) -> None:
        """Close the bar."""
        self.close()
