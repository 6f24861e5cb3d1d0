"""A replay's figures over its per-frame rows, for the terminal and the summary JSON.

``summarize(rows, budget_ms, encode_ms=..., encoded_frames=...)`` returns a dict with
exactly these keys (``SUMMARY_KEYS``; a contract: scripts read them):

- ``frames`` (int): rows summarised.
- ``budget_ms`` (float): the frame-time budget the percentages use.
- ``within_budget_pct``: percent of frames with ``frame_ms <= budget_ms``.
- ``within_budget_plus_10_pct``: percent of frames with ``frame_ms <= 1.1 * budget_ms``.
- ``mean_traced_pct``: mean ``traced_fraction`` x 100, the traced area in percent of the
  screen (the paper's figure).
- ``frame_ms_mean``, ``frame_ms_median``, ``frame_ms_p95``: frame time in ms; the 95th
  percentile is numpy's default (``method="linear"``: linear interpolation between the
  two nearest ranks).
- ``encode_ms_mean``: the video encoder's mean time per frame in ms (``encode_ms`` over
  ``encoded_frames``, which defaults to the number of rows), or ``None`` without a video.

Both percentages are counted from ``frame_ms`` against the ``budget_ms`` given, so they
are comparable (the rows' own ``within_budget`` flags are not read).  With no rows every
figure but ``frames`` and ``budget_ms`` is ``None``.  Values are plain Python numbers,
unrounded (``format_summary`` rounds for display).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

#: The keys of ``summarize``'s dict, in order.
SUMMARY_KEYS = (
    "frames",
    "budget_ms",
    "within_budget_pct",
    "within_budget_plus_10_pct",
    "mean_traced_pct",
    "frame_ms_mean",
    "frame_ms_median",
    "frame_ms_p95",
    "encode_ms_mean",
)

# "Within budget + 10%": frame time up to this many budgets.
_SLACK = 1.1


def summarize(
    rows: Iterable[Mapping[str, Any]],
    budget_ms: float,
    *,
    encode_ms: float | None = None,
    encoded_frames: int | None = None,
) -> dict[str, Any]:
    """The replay's figures (keys and meaning in the module docstring) over ``rows``
    (each with ``frame_ms`` and ``traced_fraction``, as ``StatsWriter`` writes them or
    ``read_stats`` returns them).  ``encode_ms``: the encoder's total time
    (``VideoWriter.encode_ms``), ``encoded_frames`` its frame count (``VideoWriter.frames``;
    default: the number of rows)."""
    budget_ms = float(budget_ms)
    if not (math.isfinite(budget_ms) and budget_ms > 0.0):
        raise ValueError(f"budget_ms must be a positive number, got {budget_ms}")
    rows = list(rows)
    frame_ms = np.array([float(row["frame_ms"]) for row in rows], dtype=np.float64)
    traced = np.array([float(row["traced_fraction"]) for row in rows], dtype=np.float64)
    frames = len(rows)
    if encoded_frames is None:
        encoded_frames = frames
    summary: dict[str, Any] = dict.fromkeys(SUMMARY_KEYS)
    summary["frames"] = frames
    summary["budget_ms"] = budget_ms
    if encode_ms is not None and encoded_frames > 0:
        summary["encode_ms_mean"] = float(encode_ms) / encoded_frames
    if frames == 0:
        return summary
    summary["within_budget_pct"] = 100.0 * int(np.count_nonzero(frame_ms <= budget_ms)) / frames
    summary["within_budget_plus_10_pct"] = 100.0 * int(np.count_nonzero(frame_ms <= _SLACK * budget_ms)) / frames
    summary["mean_traced_pct"] = 100.0 * float(traced.mean())
    summary["frame_ms_mean"] = float(frame_ms.mean())
    summary["frame_ms_median"] = float(np.median(frame_ms))
    summary["frame_ms_p95"] = float(np.percentile(frame_ms, 95))
    return summary


def format_summary(summary: Mapping[str, Any]) -> str:
    """A few readable lines (no trailing newline) for the terminal; figures that are
    ``None`` read ``n/a``, and the encoder line is left out without a video."""

    def number(key: str, digits: int, unit: str = "") -> str:
        value = summary.get(key)
        return "n/a" if value is None else f"{value:.{digits}f}{unit}"

    lines = [
        f"frames: {summary['frames']} (budget {number('budget_ms', 3, ' ms')})",
        f"within budget: {number('within_budget_pct', 1, '%')}"
        f" (within budget + 10%: {number('within_budget_plus_10_pct', 1, '%')})",
        f"traced area: {number('mean_traced_pct', 2, '%')} of the screen (mean)",
        f"frame time: mean {number('frame_ms_mean', 2, ' ms')}, median {number('frame_ms_median', 2, ' ms')},"
        f" p95 {number('frame_ms_p95', 2, ' ms')}",
    ]
    if summary.get("encode_ms_mean") is not None:
        lines.append(f"video encoding: {number('encode_ms_mean', 2, ' ms')} per frame (mean, off the render thread)")
    errors = summary.get("errors")
    if errors:
        lines.append(
            f"error against {errors['reference_spp']}-spp references (median over {errors['frames']} frames): "
            f"foveated FLIP {errors['median_flip_foveated']:.4f}, inside the window "
            f"{errors['median_flip_inside']:.4f}, outside {errors['median_flip_outside']:.4f}, "
            f"PSNR {errors['median_psnr']:.2f} dB"
        )
    return "\n".join(lines)
