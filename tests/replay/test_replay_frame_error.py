"""A replay's per-frame error against full ray-traced references of the same frames:
zero where the frame is the reference, the window closer to it than the periphery, the
references following the animation, and the command line's file and summary."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from gaze.fixed import FixedSource
from warp_hybrid.cli import main
from warp_hybrid.renderer import RenderSettings
from warp_hybrid.replay.frame_error import ERROR_COLUMNS, error_summary
from warp_hybrid.replay.loop import AdaptiveLoop, LoopSettings
from warp_hybrid.replay.run import ReplayOutputs, replay
from warp_hybrid.scene.open import open_scene_source

ROOT = Path(__file__).resolve().parents[2]
ANIMATED = ROOT / "scenes" / "textured_animated.usda"
CORNELL = ROOT / "scenes" / "cornell_glass.usda"
W, H = 48, 36


def _errors(tmp_path: Path, device: str, scene: Path, error_spp: int, **settings) -> tuple[list[dict], dict]:
    outputs = ReplayOutputs(errors=tmp_path / "errors.csv", error_spp=error_spp)
    render = RenderSettings(width=W, height=H, device=device, threads=1, **settings)
    loop_settings = LoopSettings(fps=6.0, adaptive=False)
    with AdaptiveLoop(open_scene_source(scene), render, loop_settings) as loop:
        result = replay(loop, FixedSource(0.4, 0.5), 4, outputs, warm_up=0, progress=False)
    with open(outputs.errors) as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(ERROR_COLUMNS)
    return rows, result.summary


def test_a_frame_that_is_its_reference_has_no_error(tmp_path: Path, device: str) -> None:
    """Full ray tracing at one sample against one-sample references of the same (moving)
    frames: the images are identical, whatever each frame's automatic exposure."""
    rows, summary = _errors(tmp_path, device, ANIMATED, 1, mode="full")
    assert [int(r["frame"]) for r in rows] == [0, 1, 2, 3]
    assert len({r["exposure_ev"] for r in rows}) >= 1
    for r in rows:
        assert float(r["flip_mean"]) == 0.0 and float(r["flip_foveated"]) == 0.0
        assert float(r["psnr"]) == float("inf")
    assert summary["errors"]["frames"] == 4 and summary["errors"]["median_flip_foveated"] == 0.0


def test_the_window_is_closer_to_the_reference_than_the_periphery(tmp_path: Path, device: str) -> None:
    """Glass, mirrors and shadows: traced inside the window, rasterized (no shadows, no
    refraction) outside it."""
    rows, summary = _errors(tmp_path, device, CORNELL, 4, mode="hybrid", window_fraction=0.3, feather_px=2.0)
    for r in rows:
        assert float(r["window_fraction"]) == pytest.approx(0.3)
        assert (float(r["gaze_x"]), float(r["gaze_y"])) == (0.4, 0.5)
        assert 0.0 < float(r["flip_inside"]) < float(r["flip_outside"])
    assert summary["errors"]["median_flip_inside"] == pytest.approx(
        error_summary(rows)["median_flip_inside"], abs=1e-12
    )


def test_replay_error_csv_from_the_command_line(tmp_path: Path, capsys) -> None:
    errors, summary = tmp_path / "errors.csv", tmp_path / "summary.json"
    args = ["replay", str(ANIMATED), "--gaze", "fixed:0.5,0.5", "--frames", "2", "--size", f"{W}x{H}"]
    args += ["--window", "0.2", "--warm-up", "0", "--threads", "1"]
    assert main([*args, "--error-csv", str(errors), "--error-spp", "2", "--summary-json", str(summary)]) == 0
    assert "error against 2-spp references (median over 2 frames)" in capsys.readouterr().out
    assert len(errors.read_text().splitlines()) == 3
    assert json.loads(summary.read_text())["errors"]["reference_spp"] == 2
    assert main([*args, "--error-csv", str(tmp_path / "bad.csv"), "--error-spp", "0"]) == 2
    assert "samples per pixel must be in 1..256" in capsys.readouterr().err
    assert not (tmp_path / "bad.csv").exists()
