"""What a reader hands on: the sample rows of a file before validation, and the shared
rules readers apply to them (combining two eyes, the pixel size of pixel coordinates)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gaze.errors import GazeError


@dataclass(frozen=True)
class Samples:
    """The sample rows of one file, in file order.

    ``t`` is in seconds from any origin; ``x, y`` are normalised top-left (NaN where the
    row has no point); ``lines`` holds each row's line number.  ``flags`` names why the
    file itself marks samples as not measured (reason -> mask); ``skipped`` counts the
    rows that are not samples at all (reason -> count).  ``recording`` holds each row's
    recording id where the file has a recording column; ``notes`` describe what the
    reader took from elsewhere (e.g. the pixel size and where it came from).
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    lines: np.ndarray
    confidence: np.ndarray | None = None
    flags: dict[str, np.ndarray] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)
    recording: np.ndarray | None = None
    notes: dict[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def subset(self, mask: np.ndarray) -> Samples:
        """The rows where ``mask`` is True (file-level ``skipped`` and ``notes`` stay whole)."""
        return Samples(
            self.t[mask],
            self.x[mask],
            self.y[mask],
            self.lines[mask],
            None if self.confidence is None else self.confidence[mask],
            {reason: flag[mask] for reason, flag in self.flags.items()},
            self.skipped,
            None if self.recording is None else self.recording[mask],
            self.notes,
        )


def combine_eyes(
    left: tuple[np.ndarray, np.ndarray, np.ndarray], right: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One gaze point from two eyes, each ``(x, y, valid)``: the mean where both eyes are valid
    and have a point, the one eye where only it does; NaN (and not valid) where neither does."""
    ok = [np.asarray(v, bool) & np.isfinite(x) & np.isfinite(y) for x, y, v in (left, right)]
    count = ok[0].astype(float) + ok[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (np.where(ok[0], left[0], 0.0) + np.where(ok[1], right[0], 0.0)) / count
        y = (np.where(ok[0], left[1], 0.0) + np.where(ok[1], right[1], 0.0)) / count
    valid = count > 0
    return np.where(valid, x, np.nan), np.where(valid, y, np.nan), valid


def pixel_size(
    where: str,
    screen_px: tuple[int, int] | None,
    found: tuple[tuple[int, int], str] | None,
    what: str,
    hint: str = "give --screen WxH (trace: ?screen=WxH)",
) -> tuple[tuple[int, int], str]:
    """The pixel size of pixel coordinates and where it came from: the caller's ``screen_px``
    first, else ``found`` (a size the file, or a file beside it, holds, and where it came
    from), else a ``GazeError`` saying ``what`` the pixels are of, and ``hint``."""
    if screen_px is not None:
        return screen_px, "--screen / screen="
    if found is not None:
        return found
    raise GazeError(where, f"gaze points are pixels of {what} but there is no screen size; {hint}")


def pixel_note(size: tuple[int, int], source: str, what: str) -> dict[str, str]:
    """The ``Samples.notes`` entry that says which pixel size was used, of what, and whence."""
    return {"pixels": f"{size[0]}x{size[1]} ({what}; {source})"}
