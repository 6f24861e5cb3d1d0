"""The replay summary: exact figures on hand-made rows, the key contract, the terminal text."""

from __future__ import annotations

import json

import pytest

from warp_hybrid.replay.summary import SUMMARY_KEYS, format_summary, summarize

FRAME_MS = (30.0, 10.0, 17.0, 16.0, 18.0)
TRACED = (0.1, 0.2, 0.3, 0.4, 0.5)
ROWS = [{"frame_ms": ms, "traced_fraction": f, "within_budget": False} for ms, f in zip(FRAME_MS, TRACED)]


def test_summary_figures() -> None:
    summary = summarize(ROWS, 16.0, encode_ms=10.0)
    assert tuple(summary) == SUMMARY_KEYS
    assert summary["frames"] == 5
    assert summary["budget_ms"] == 16.0
    # frame_ms <= 16: 10 and 16 (the rows' within_budget flags are not read).
    assert summary["within_budget_pct"] == 40.0
    # frame_ms <= 17.6: 10, 16 and 17.
    assert summary["within_budget_plus_10_pct"] == 60.0
    assert summary["mean_traced_pct"] == pytest.approx(30.0, rel=1e-12)
    assert summary["frame_ms_mean"] == pytest.approx(18.2, rel=1e-12)
    assert summary["frame_ms_median"] == 17.0
    # numpy's default percentile (method="linear"): sorted 10, 16, 17, 18, 30; rank 0.95 * 4 = 3.8,
    # so 18 + 0.8 * (30 - 18).
    assert summary["frame_ms_p95"] == pytest.approx(27.6, rel=1e-12)
    assert summary["encode_ms_mean"] == 2.0
    json.dumps(summary)  # plain Python numbers


def test_encode_mean_uses_the_encoders_frame_count() -> None:
    assert summarize(ROWS, 16.0, encode_ms=12.0, encoded_frames=4)["encode_ms_mean"] == 3.0
    assert summarize(ROWS, 16.0)["encode_ms_mean"] is None


def test_empty_summary() -> None:
    summary = summarize([], 20.0)
    assert summary["frames"] == 0
    assert all(summary[key] is None for key in SUMMARY_KEYS if key not in ("frames", "budget_ms"))
    assert "n/a" in format_summary(summary)
    with pytest.raises(ValueError, match="budget_ms"):
        summarize(ROWS, 0.0)


def test_format_summary() -> None:
    text = format_summary(summarize(ROWS, 16.0, encode_ms=10.0))
    assert text.splitlines() == [
        "frames: 5 (budget 16.000 ms)",
        "within budget: 40.0% (within budget + 10%: 60.0%)",
        "traced area: 30.00% of the screen (mean)",
        "frame time: mean 18.20 ms, median 17.00 ms, p95 27.60 ms",
        "video encoding: 2.00 ms per frame (mean, off the render thread)",
    ]
    assert "video encoding" not in format_summary(summarize(ROWS, 16.0))
