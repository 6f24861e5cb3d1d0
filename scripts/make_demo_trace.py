"""Write the demo gaze trace, scenes/traces/demo_gaze.csv (simple CSV, normalised top-left).

5 s at 60 Hz (301 samples, t = 0 .. 5 s): five fixations with a small deterministic
jitter (sums of sines, ~0.1 deg), minimum-jerk saccades of 50 ms between them, and
one 150 ms blink (rows ``t,,,0``) during the second fixation.  No randomness, so a
rerun gives a byte-identical file.  ``make demo`` samples it at the scene's time.

    .venv/bin/python scripts/make_demo_trace.py            # writes scenes/traces/demo_gaze.csv
    .venv/bin/python scripts/make_demo_trace.py OUT.csv    # or anywhere else
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # runnable as a plain script from a checkout
    sys.path.insert(0, str(ROOT))

from gaze.trace.simple_csv import write_simple  # noqa: E402

RATE_HZ = 60.0
DURATION_S = 5.0
SACCADE_S = 0.05
#: (start time of the fixation in s, x, y); each saccade ends at its fixation's start.
FIXATIONS = (
    (0.00, 0.36, 0.66),
    (0.85, 0.62, 0.40),
    (2.45, 0.50, 0.22),
    (3.45, 0.30, 0.45),
    (4.25, 0.55, 0.70),
)
#: The blink, [start, end) in seconds: rows with no point and confidence 0.
BLINK_S = (1.90, 2.05)
JITTER = 0.0025  # normalised amplitude of the fixation jitter (~1.3 mm, ~0.13 deg at 60 cm on 53 cm)


def min_jerk(u: np.ndarray) -> np.ndarray:
    """The minimum-jerk position profile 10u^3 - 15u^4 + 6u^5 on u in [0, 1]."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u * u)


def demo_trace() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The demo samples: t, x, y, confidence, valid."""
    t = np.arange(int(round(DURATION_S * RATE_HZ)) + 1) / RATE_HZ
    x = np.full(t.shape, FIXATIONS[0][1])
    y = np.full(t.shape, FIXATIONS[0][2])
    for (_, x0, y0), (start, x1, y1) in zip(FIXATIONS[:-1], FIXATIONS[1:]):
        s = min_jerk((t - (start - SACCADE_S)) / SACCADE_S)
        moving = t >= start - SACCADE_S
        x = np.where(moving, x0 + s * (x1 - x0), x)
        y = np.where(moving, y0 + s * (y1 - y0), y)
    x = x + JITTER * (0.6 * np.sin(2 * np.pi * 1.3 * t) + 0.4 * np.sin(2 * np.pi * 3.7 * t + 1.0))
    y = y + JITTER * (0.6 * np.sin(2 * np.pi * 1.9 * t + 2.0) + 0.4 * np.sin(2 * np.pi * 4.3 * t + 0.5))
    confidence = 0.97 + 0.02 * np.sin(2 * np.pi * 0.7 * t)
    valid = ~((t >= BLINK_S[0]) & (t < BLINK_S[1]))
    return t, x, y, np.where(valid, confidence, 0.0), valid


def main(argv: list[str] | None = None) -> int:
    """Write the trace to the given path (default scenes/traces/demo_gaze.csv)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?", default=str(ROOT / "scenes" / "traces" / "demo_gaze.csv"))
    args = parser.parse_args(argv)
    t, x, y, confidence, valid = demo_trace()
    write_simple(args.output, t, x, y, confidence, valid)
    print(f"{args.output}: {t.size} samples, {int((~valid).sum())} blink rows")
    return 0


if __name__ == "__main__":
    sys.exit(main())
