"""The gaze command line: convert end to end, parsing under a parent program, webcam dispatch;
and the shipped demo trace."""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from gaze.cli import add_gaze_parser, build_parser, run_gaze
from gaze.errors import GazeError
from gaze.source import SACCADE
from gaze.trace.detect import read_trace
from gaze.trace.playback import TraceSource
from gaze.trace.simple_csv import format_simple

ROOT = Path(__file__).resolve().parents[2]
TOBII = (
    "Recording timestamp [ms]\tSensor\tGaze point X\tGaze point Y\n"
    "500\tEye Tracker\t960\t540\n"
    "510\tGyroscope\t\t\n"
    "516.5\tEye Tracker\t\t\n"
    "533\tEye Tracker\t192\t1080\n"
)


def test_convert_through_run_gaze(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / "export.tsv"
    src.write_text(TOBII, encoding="utf-8")
    out = tmp_path / "trace.csv"
    args = build_parser().parse_args(["convert", str(src), str(out), "--screen", "1920x1080"])
    assert run_gaze(args) == 0
    assert out.read_text().splitlines() == [
        "t,x,y,confidence",
        "0.000000,0.500000,0.500000,1.0000",
        "0.016500,,,0",
        "0.033000,0.100000,1.000000,1.0000",
    ]
    assert "3 samples (2 valid)" in capsys.readouterr().out


def test_convert_failure_leaves_no_partial_file(tmp_path: Path) -> None:
    src = tmp_path / "export.tsv"
    src.write_text(TOBII, encoding="utf-8")
    out = tmp_path / "trace.csv"
    out.write_text("previous\n", encoding="utf-8")
    args = build_parser().parse_args(["convert", str(src), str(out)])  # no screen size: an error
    with pytest.raises(GazeError, match=r"export\.tsv.*no screen size"):
        run_gaze(args)
    assert out.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["export.tsv", "trace.csv"]


def run_module(*argv: str) -> subprocess.CompletedProcess[str]:
    """``python -m gaze ARGV`` from the repository root."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "gaze", *argv],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
        timeout=60,
        check=False,
    )


def test_python_m_gaze_convert(tmp_path: Path) -> None:
    src = tmp_path / "gaze_positions.csv"
    src.write_text(
        "gaze_timestamp,confidence,norm_pos_x,norm_pos_y\n9.5,0.9,0.5,0.2\n9.6,0.9,0.1,0.9\n", encoding="utf-8"
    )
    out = tmp_path / "out.csv"
    done = run_module("convert", str(src), str(out), "--format", "pupil")
    assert done.returncode == 0, done.stderr
    data = read_trace(out)
    np.testing.assert_allclose(data.t, [0.0, 0.1], atol=1e-6)
    np.testing.assert_allclose(np.c_[data.x, data.y], [[0.5, 0.8], [0.1, 0.1]], atol=1e-6)

    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y\n0,0.1,0.1\n0,0.2,0.2\n", encoding="utf-8")
    failed = run_module("convert", str(bad), str(tmp_path / "never.csv"))
    assert failed.returncode == 2
    assert failed.stderr.strip() == f"error: {bad}: line 3: duplicate timestamp (0.0 s)"
    assert not (tmp_path / "never.csv").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "gaze_positions.csv", "out.csv"]


def parent_parser() -> argparse.ArgumentParser:
    """A stand-in for the renderer's program with the gaze sub-command added."""
    parser = argparse.ArgumentParser(prog="parent")
    add_gaze_parser(parser.add_subparsers(dest="command", required=True))
    return parser


def test_gaze_sub_command_arguments() -> None:
    parser = parent_parser()
    args = parser.parse_args(
        ["gaze", "record", "--source", "webcam:0", "--calibration", "c.json", "--out", "t.csv", "--screen", "1920x1080"]
    )
    assert (args.command, args.gaze_command, args.source, args.calibration, args.out, args.screen) == (
        "gaze",
        "record",
        "webcam:0",
        "c.json",
        "t.csv",
        (1920, 1080),
    )
    args = parser.parse_args(
        ["gaze", "calibrate", "--source", "clip.mp4", "--targets", "targets.csv", "--out", "calib.json"]
    )
    assert (args.gaze_command, args.source, args.targets, args.out) == (
        "calibrate",
        "clip.mp4",
        "targets.csv",
        "calib.json",
    )
    assert parser.parse_args(["gaze", "calibrate", "--source", "webcam:0", "--out", "c.json"]).targets is None
    args = parser.parse_args(["gaze", "convert", "in.tsv", "out.csv"])
    assert (args.input, args.output, args.format, args.screen, args.min_confidence) == (
        "in.tsv",
        "out.csv",
        None,
        None,
        0.6,
    )
    for bad in (
        ["gaze", "convert", "a", "b", "--screen", "1920by1080"],
        ["gaze", "record", "--source", "webcam:0"],
        ["gaze", "convert", "a", "b", "--format", "xml"],
        ["gaze"],
    ):
        with pytest.raises(SystemExit):
            parser.parse_args(bad)


def test_webcam_commands_dispatch(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[str, str]] = []
    module = types.ModuleType("gaze.webcam.commands")
    module.run_calibrate = lambda a: calls.append(("calibrate", a.out)) or 0  # type: ignore[attr-defined]
    module.run_record = lambda a: calls.append(("record", a.out)) or 3  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "gaze.webcam.commands", module)
    parser = parent_parser()
    assert run_gaze(parser.parse_args(["gaze", "calibrate", "--source", "webcam:0", "--out", "c.json"])) == 0
    assert (
        run_gaze(
            parser.parse_args(["gaze", "record", "--source", "v.mp4", "--calibration", "c.json", "--out", "t.csv"])
        )
        == 3
    )
    assert calls == [("calibrate", "c.json"), ("record", "t.csv")]
    monkeypatch.setitem(sys.modules, "gaze.webcam.commands", None)
    with pytest.raises(GazeError, match="gaze record: the webcam estimator is not available"):
        run_gaze(
            parser.parse_args(["gaze", "record", "--source", "v.mp4", "--calibration", "c.json", "--out", "t.csv"])
        )


def test_demo_trace() -> None:
    path = ROOT / "scenes" / "traces" / "demo_gaze.csv"
    source = TraceSource.from_file(path)
    data = source.data
    assert data.format == "simple" and len(data) == 301 and data.duration == pytest.approx(5.0)
    assert data.t[1] == pytest.approx(1 / 60, abs=1e-6)
    # exactly one blink: 9 consecutive rows (150 ms) with no point and confidence 0
    blink = np.flatnonzero(~data.valid)
    assert blink.tolist() == list(range(blink[0], blink[0] + 9))
    np.testing.assert_array_equal(data.confidence[blink], 0.0)
    held = source.sample(float(data.t[blink[4]]))
    before = source.sample(float(data.t[blink[0] - 1]))
    assert not held.valid and (held.x, held.y) == pytest.approx((before.x, before.y), abs=0.01)
    # four saccades between five fixations, each a short run of saccade labels
    saccade = (source.labels == SACCADE).astype(int)
    assert int(np.sum(np.diff(saccade) == 1)) == 4 and saccade.sum() <= 20
    assert (data.x[data.valid].min() >= 0.0) and (data.y[data.valid].max() <= 1.0)


def test_demo_trace_is_reproducible() -> None:
    spec = importlib.util.spec_from_file_location("make_demo_trace", ROOT / "scripts" / "make_demo_trace.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    fresh = format_simple(*module.demo_trace())
    assert fresh == (ROOT / "scenes" / "traces" / "demo_gaze.csv").read_text(), "rerun scripts/make_demo_trace.py"


def test_info_text_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / "export.tsv"
    src.write_text(TOBII + "550\tEye Tracker\t99999\t540\n566.5\tEye", encoding="utf-8")
    args = build_parser().parse_args(["info", str(src), "--screen", "1920x1080"])
    assert run_gaze(args) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"{src}: Tobii Pro Lab TSV export (format tobii)",
        "  recordings: 1",
        "  pixels: 1920x1080 (the recording's screen; --screen / screen=)",
        "  skipped rows: 1 last row cut off, 1 Sensor is not 'Eye Tracker' (mouse, gyroscope, event rows)",
        "  recording: 4 samples over 0.050 s at 60.6 Hz, 50.0% valid; invalid: 1 no gaze point, 1 outside the screen",
    ]
    assert run_gaze(build_parser().parse_args(["info", str(src), "--screen", "1920x1080", "--json"])) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["format"] == "tobii" and report["recordings_in_file"] == 1
    assert report["skipped"] == {"last row cut off": 1, "Sensor is not 'Eye Tracker' (mouse, gyroscope, event rows)": 1}
    (rec,) = report["recordings"]
    assert (rec["id"], rec["samples"], rec["valid"], rec["valid_share"]) == (None, 4, 2, 0.5)
    assert rec["duration_s"] == pytest.approx(0.05) and rec["rate_hz"] == pytest.approx(1 / 0.0165)
    assert rec["invalid"] == {"no gaze point": 1, "outside the screen": 1}


def test_info_lists_every_recording_and_reports_unreadable_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = tmp_path / "gaze.csv"
    src.write_text(
        "recording id,timestamp [ns],gaze detected on surface,gaze position on surface x [normalized],"
        "gaze position on surface y [normalized]\n"
        "aaaa,1700000000000000000,True,0.5,0.5\n"
        "aaaa,1700000000005000000,True,0.6,0.6\n"
        "bbbb,1700000001000000000,False,0.1,0.1\n",
        encoding="utf-8",
    )
    assert run_gaze(build_parser().parse_args(["info", str(src)])) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"{src}: Pupil Cloud Marker Mapper gaze.csv (format marker_mapper)"
    assert lines[1] == "  recordings: 2"
    assert lines[3].startswith("  recording aaaa: 2 samples over 0.005 s at 200.0 Hz, 100.0% valid")
    assert lines[4].startswith("  recording bbbb: 1 rows, unreadable: no valid samples")
    assert run_gaze(build_parser().parse_args(["info", str(src), "--recording", "aaaa", "--json"])) == 0
    report = json.loads(capsys.readouterr().out)
    assert [r["id"] for r in report["recordings"]] == ["aaaa"] and report["recordings_in_file"] == 2


def test_info_and_convert_under_a_parent_program() -> None:
    parser = parent_parser()
    args = parser.parse_args(["gaze", "info", "t.asc", "--recording", "r1", "--json", "--format", "eyelink"])
    assert (args.gaze_command, args.input, args.recording, args.json, args.format) == (
        "info",
        "t.asc",
        "r1",
        True,
        "eyelink",
    )
    assert parser.parse_args(["gaze", "convert", "a", "b", "--recording", "x"]).recording == "x"


def test_python_m_gaze_info_bad_file(tmp_path: Path) -> None:
    bad = tmp_path / "mystery.csv"
    bad.write_text("when,where\n1,2\n", encoding="utf-8")
    done = run_module("info", str(bad))
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: {bad}: unknown columns ['when', 'where']; expected one of:")
    assert len(done.stderr.strip().splitlines()) == 1
