"""SR Research EyeLink ``.asc`` files (EDF2ASC output), read line by line.

Sample lines start with the time in ms, then the gaze in screen pixels and the pupil
size per recorded eye (``.`` where missing); which eyes a block holds is the
``SAMPLES GAZE LEFT|RIGHT ...`` line before it (monocular and binocular blocks may
follow each other in one file; velocity, resolution and flag fields after the pupil
are ignored).  With both eyes the point is their mean (one eye where only it has a
point).  The screen is the caller's size, else the ``DISPLAY_COORDS`` message (else
``GAZE_COORDS``): ``left top right bottom`` in pixels.  Header (``**``), message,
event and other control lines are skipped and counted.
"""

from __future__ import annotations

import numpy as np

from gaze.errors import GazeError
from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples, combine_eyes, pixel_note, pixel_size
from gaze.trace.table import CUT_OFF
from gaze.trace.text import TraceText

FORMAT = "eyelink"
#: First words of the lines EDF2ASC writes that are not samples (for detection).
KEYWORDS = frozenset({"MSG", "START", "END", "SAMPLES", "EVENTS", "PRESCALER", "VPRESCALER", "PUPIL", "INPUT"})
COORDS = ("DISPLAY_COORDS", "GAZE_COORDS")
NOT_SAMPLES = "header, message and event lines"
WHAT = "the display"


def is_asc(first_line: str) -> bool:
    """True when a file's first non-blank line is an EDF2ASC header or control line."""
    words = first_line.split()
    return first_line.startswith("**") or (bool(words) and words[0] in KEYWORDS)


def _number(word: str) -> float:
    """A sample field: ``.`` (missing) is NaN."""
    return float("nan") if word == "." else float(word)


def _screen(
    where: str, coords: dict[str, tuple[int, ...]], screen_px: tuple[int, int] | None
) -> tuple[tuple[int, int], tuple[int, int], str]:
    """The pixel origin and size of the gaze coordinates, and where they came from."""
    found = next(((name, coords[name]) for name in COORDS if name in coords), None)
    if screen_px is not None or found is None:
        size, source = pixel_size(where, screen_px, None, WHAT)
        return (0, 0), size, source
    name, (left, top, right, bottom) = found
    return (left, top), (right - left + 1, bottom - top + 1), f"{name} message"


def _coords(where: str, number: int, words: list[str], coords: dict[str, tuple[int, ...]]) -> None:
    """Record the first ``DISPLAY_COORDS`` / ``GAZE_COORDS left top right bottom`` in ``coords``."""
    for name in COORDS:
        if name in words and name not in coords:
            at = words.index(name)
            try:
                left, top, right, bottom = (round(float(w)) for w in words[at + 1 : at + 5])
            except ValueError:
                raise GazeError(where, f"line {number}: {name} needs four numbers: {' '.join(words)!r}") from None
            if right <= left or bottom <= top:
                raise GazeError(where, f"line {number}: {name} is not a screen: {' '.join(words)!r}")
            coords[name] = (left, top, right, bottom)


def asc_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of an ASC file (see the module notes)."""
    where = text.path
    lines = text.text.splitlines()
    eyes: int | None = None
    coords: dict[str, tuple[int, ...]] = {}
    rows: list[tuple[float, float, float, float, float]] = []
    numbers: list[int] = []
    other = cut = 0
    nan = float("nan")
    for number, line in enumerate(lines, start=1):
        words = line.split()
        if not words:
            continue
        if not words[0][0].isdigit():
            other += 1
            if words[0] == "SAMPLES":
                if "GAZE" not in words:
                    raise GazeError(where, f"line {number}: the samples are not screen gaze (SAMPLES without GAZE)")
                eyes = ("LEFT" in words) + ("RIGHT" in words)
            else:
                _coords(where, number, words, coords)
            continue
        if not eyes:
            raise GazeError(where, f"line {number}: a sample before any 'SAMPLES GAZE LEFT|RIGHT' line says which eyes")
        need = 1 + 3 * eyes
        if len(words) < need:
            if number == len(lines) and not text.text.endswith(("\n", "\r")):
                cut += 1
                continue
            kind = "binocular" if eyes == 2 else "monocular"
            raise GazeError(where, f"line {number}: a {kind} sample needs {need} fields, got {len(words)}")
        try:
            values = [_number(w) for w in words[:need]]
        except ValueError:
            raise GazeError(where, f"line {number}: not a sample: {line.strip()!r}") from None
        rows.append((values[0], values[1], values[2], *(values[4:6] if eyes == 2 else (nan, nan))))
        numbers.append(number)
    if not rows:
        raise GazeError(where, "no sample lines (is it an events-only ASC? convert the EDF with samples)")
    data = np.array(rows, dtype=float)
    x, y, _ = combine_eyes((data[:, 1], data[:, 2], True), (data[:, 3], data[:, 4], True))
    (x0, y0), size, source = _screen(where, coords, screen_px)
    skipped = {name: n for name, n in ((NOT_SAMPLES, other), (CUT_OFF, cut)) if n}
    return Samples(
        data[:, 0] * 1e-3,
        (x - x0) / size[0],
        (y - y0) / size[1],
        np.array(numbers, dtype=int),
        skipped=skipped,
        notes=pixel_note(size, source, WHAT),
    )


READER = TraceFormat(
    FORMAT,
    "EyeLink EDF2ASC .asc",
    "'** CONVERTED FROM ...' header, SAMPLES/MSG lines, samples 'time x y pupil ...'",
    lambda text: is_asc(text.first_line),
    asc_samples,
)
