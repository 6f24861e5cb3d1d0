"""The per-frame stats CSV: the column contract, formatting, whole rows after an interruption."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from warp_hybrid.errors import WarpHybridError
from warp_hybrid.replay.stats_csv import FIXED_COLUMNS, RAY_COLUMNS, StatsWriter, read_stats, stats_columns

HEADER = (
    "frame,t,gaze_x,gaze_y,gaze_valid,saccade,window_fraction,traced_fraction,frame_ms,budget_ms,within_budget,"
    "raster_ms,trace_shadow_ms,compose_ms,rays_shadow,rays_reflection,rays_refraction"
)
STAGES = ("raster", "trace_shadow", "compose")


def make_row(frame: int, **extra: Any) -> dict[str, Any]:
    row = {
        "frame": frame,
        "t": frame / 60.0,
        "gaze_x": 0.25,
        "gaze_y": 0.75,
        "gaze_valid": True,
        "saccade": False,
        "window_fraction": 0.25,
        "traced_fraction": 0.2,
        "frame_ms": 16.0 + frame,
        "budget_ms": 1000.0 / 60.0,
        "within_budget": frame == 0,
        "raster_ms": 1.23456,
        "trace_shadow_ms": 7.0,
        "rays_shadow": 1000,
        "rays_reflection": 20,
        "rays_refraction": 0,
    }
    row.update(extra)
    return row


def test_header_is_the_contract_plus_stage_columns(tmp_path: Path) -> None:
    assert FIXED_COLUMNS == tuple(HEADER.split(",")[:11])
    assert RAY_COLUMNS == ("rays_shadow", "rays_reflection", "rays_refraction")
    assert stats_columns(STAGES) == tuple(HEADER.split(","))
    path = tmp_path / "stats.csv"
    with StatsWriter(path, STAGES) as writer:
        assert writer.columns == tuple(HEADER.split(","))
    assert path.read_text() == HEADER + "\n"
    assert read_stats(path) == []


def test_rows_are_formatted_and_read_back(tmp_path: Path) -> None:
    path = tmp_path / "stats.csv"
    with StatsWriter(path, STAGES) as writer:
        writer.write_row(make_row(0))
        writer.write_row(make_row(1, saccade=1, gaze_valid=0))
    lines = path.read_text().splitlines()
    # compose_ms is missing from the rows: written as 0.
    assert lines[1] == "0,0.000000,0.250000,0.750000,1,0,0.250000,0.200000,16.000,16.667,1,1.235,7.000,0.000,1000,20,0"
    rows = read_stats(path)
    assert len(rows) == 2
    assert list(rows[1]) == list(stats_columns(STAGES))
    assert rows[1]["frame"] == 1 and isinstance(rows[1]["frame"], int)
    assert rows[1]["saccade"] is True and rows[1]["gaze_valid"] is False and rows[1]["within_budget"] is False
    assert rows[1]["t"] == pytest.approx(1 / 60.0, abs=1e-6)
    assert rows[1]["raster_ms"] == 1.235 and rows[1]["compose_ms"] == 0.0
    assert rows[0]["rays_shadow"] == 1000


def test_bad_rows_are_refused_whole(tmp_path: Path) -> None:
    path = tmp_path / "stats.csv"
    with StatsWriter(path, STAGES) as writer:
        with pytest.raises(ValueError, match="unknown stats columns: lighting_ms"):
            writer.write_row(make_row(0, lighting_ms=3.0))
        row = make_row(0)
        del row["traced_fraction"]
        with pytest.raises(ValueError, match="row without traced_fraction"):
            writer.write_row(row)
        with pytest.raises(ValueError, match="column saccade: expected a boolean"):
            writer.write_row(make_row(0, saccade=2))
        with pytest.raises(ValueError, match="column rays_shadow"):
            writer.write_row(make_row(0, rays_shadow=1.5))
        writer.write_row(make_row(0))
        assert writer.rows == 1
    assert len(read_stats(path)) == 1
    with pytest.raises(ValueError, match="stage name"):
        StatsWriter(tmp_path / "bad.csv", ["ray,cast"])
    with pytest.raises(ValueError, match="repeated columns: raster_ms"):
        stats_columns(["raster", "raster"])
    assert list(tmp_path.iterdir()) == [path]


def test_interrupted_replay_leaves_whole_rows(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        path = tmp_path / "out" / "stats.csv"
        writer = StatsWriter(path, STAGES)
        with pytest.raises(KeyboardInterrupt):
            try:
                for frame in range(10):
                    if frame == 3:
                        writer._out.write(b"3,0.05")  # a row torn by the interruption, never flushed whole
                        raise KeyboardInterrupt
                    writer.write_row(make_row(frame))
                    assert not path.exists()
            finally:
                writer.close()
    finally:
        os.umask(old)
    text = path.read_text()
    assert text.endswith("\n") and len(text.splitlines()) == 4
    assert [row["frame"] for row in read_stats(path)] == [0, 1, 2]
    assert os.stat(path).st_mode & 0o777 == 0o644
    assert [p.name for p in path.parent.iterdir()] == ["stats.csv"]
    writer.close()  # a second close is a no-op
    with pytest.raises(WarpHybridError, match="write after close"):
        writer.write_row(make_row(4))


def test_read_stats_names_the_file(tmp_path: Path) -> None:
    with pytest.raises(WarpHybridError, match="missing.csv: cannot read"):
        read_stats(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("frame,t\n0,0\n")
    with pytest.raises(WarpHybridError, match="bad.csv: not a stats CSV header"):
        read_stats(bad)
    torn = tmp_path / "torn.csv"
    torn.write_text(",".join(stats_columns([])) + "\n0,0.1\n")
    with pytest.raises(WarpHybridError, match="torn.csv: line 2: 2 cells"):
        read_stats(torn)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    with pytest.raises(WarpHybridError, match="a_file/stats.csv: cannot create output folder"):
        StatsWriter(blocker / "stats.csv", STAGES)
