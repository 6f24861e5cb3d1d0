"""Files that join several recordings (a recording column): the choice by --recording / ?recording=,
and the refusal that lists them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from trace_fixtures import tsv

from gaze.cli import build_parser, run_gaze
from gaze.errors import GazeError
from gaze.factory import open_source
from gaze.trace.detect import read_recordings, read_trace

# Pro Lab restarts each recording's clock: the timestamps jump back where the second one starts
TOBII_JOINED = tsv(
    "Recording name|Recording timestamp [ms]|Sensor|Gaze point X|Gaze point Y",
    "Rec A|0|Eye Tracker|960|540",
    "Rec A|10|Eye Tracker|480|270",
    "Rec A|20|Eye Tracker|240|135",
    "Rec B|0|Eye Tracker|1920|1080",
    "Rec B|5|Eye Tracker|0|0",
)
CLOUD_JOINED = (
    "section id,recording id,timestamp [ns],gaze detected on surface,gaze position on surface x [normalized],"
    "gaze position on surface y [normalized],fixation id,blink id\n"
    "s1,aaaa,1700000001000000000,True,0.5,0.5,,\n"
    "s1,aaaa,1700000001004000000,True,0.6,0.6,,\n"
    "s2,bbbb,1700000000000000000,True,0.1,0.2,,\n"
    "s2,bbbb,1700000000004000000,True,0.3,0.4,,\n"
    "s2,bbbb,1700000000008000000,False,,,,\n"
)


@pytest.fixture
def joined(tmp_path: Path) -> Path:
    path = tmp_path / "joined.tsv"
    path.write_text(TOBII_JOINED, encoding="utf-8")
    return path


def test_several_recordings_are_refused_with_a_listing(joined: Path) -> None:
    with pytest.raises(GazeError) as info:
        read_trace(joined, screen_px=(1920, 1080))
    assert str(info.value) == (
        f"{joined}: holds 2 recordings; choose one with --recording ID (trace: ?recording=ID): "
        "Rec A (3 samples, 0.020 s), Rec B (2 samples, 0.005 s)"
    )


def test_each_recording_is_split_and_rebased(joined: Path) -> None:
    trace_file = read_recordings(joined, screen_px=(1920, 1080))
    assert trace_file.recording_ids == ["Rec A", "Rec B"]
    a = trace_file.trace("Rec A")
    b = trace_file.trace("Rec B")
    assert (a.recording, b.recording) == ("Rec A", "Rec B")
    np.testing.assert_allclose(a.t, [0.0, 0.01, 0.02])
    np.testing.assert_allclose(np.c_[b.t, b.x, b.y], [[0.0, 1.0, 1.0], [0.005, 0.0, 0.0]])
    with pytest.raises(GazeError, match=r"no recording 'Rec C'; the file holds Rec A \(3 samples"):
        trace_file.trace("Rec C")


def test_pupil_cloud_recording_ids(tmp_path: Path) -> None:
    path = tmp_path / "gaze.csv"
    path.write_text(CLOUD_JOINED, encoding="utf-8")
    with pytest.raises(
        GazeError, match=r"holds 2 recordings.*aaaa \(2 samples, 0\.004 s\), bbbb \(3 samples, 0\.008 s\)"
    ):
        read_trace(path)
    b = read_trace(path, recording="bbbb")
    np.testing.assert_allclose(b.t, [0.0, 0.004, 0.008], atol=1e-12)
    np.testing.assert_array_equal(b.valid, [True, True, False])


def test_recording_asked_of_a_file_without_a_recording_column(tmp_path: Path) -> None:
    path = tmp_path / "trace.csv"
    path.write_text("t,x,y\n0,0.1,0.1\n1,0.2,0.2\n", encoding="utf-8")
    with pytest.raises(GazeError, match=r"trace\.csv: recording 'x' asked for, but the file has no recording column"):
        read_trace(path, recording="x")


def test_trace_spec_recording_option(joined: Path) -> None:
    with open_source(f"trace:{joined}?screen=1920x1080&recording=Rec B") as source:
        assert (source.sample(0.0).x, source.sample(0.0).y) == (1.0, 1.0)
        assert source.duration == pytest.approx(0.005)
    with pytest.raises(GazeError, match="holds 2 recordings"):
        open_source(f"trace:{joined}?screen=1920x1080")


def test_convert_recording(joined: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b.csv"
    args = build_parser().parse_args(
        ["convert", str(joined), str(out), "--screen", "1920x1080", "--recording", "Rec B"]
    )
    assert run_gaze(args) == 0
    assert out.read_text().splitlines() == [
        "t,x,y,confidence",
        "0.000000,1.000000,1.000000,1.0000",
        "0.005000,0.000000,0.000000,1.0000",
    ]
    assert "2 samples (2 valid) over 0.005 s from tobii recording Rec B" in capsys.readouterr().out
    args = build_parser().parse_args(["convert", str(joined), str(tmp_path / "never.csv"), "--screen", "1920x1080"])
    with pytest.raises(GazeError, match="holds 2 recordings"):
        run_gaze(args)
    assert not (tmp_path / "never.csv").exists()
