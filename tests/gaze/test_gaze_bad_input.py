"""Bad trace input: a GazeError that names the file and the problem, never a crash."""

from __future__ import annotations

from pathlib import Path

import pytest

from gaze.errors import GazeError
from gaze.trace.detect import read_trace

CASES = {
    "no_valid.csv": ("t,x,y,confidence\n0,,,0\n0.1,0.5,0.5,0.2\n", r"no valid samples"),
    "unsorted.csv": (
        "t,x,y\n0,0.1,0.1\n0.2,0.2,0.2\n0.1,0.3,0.3\n",
        r"line 4: timestamp 0\.1 s is before .*unsorted",
    ),
    "duplicate.csv": ("t,x,y\n0,0.1,0.1\n0.1,0.2,0.2\n0.1,0.3,0.3\n", r"line 4: duplicate timestamp"),
    "columns.csv": ("time,gx,gy\n0,0.1,0.1\n", r"unknown columns \['time', 'gx', 'gy'\]"),
    "columns.tsv": ("Recording timestamp [ms]\tPupil diameter\n0\t3\n", r"missing column 'gaze point x'"),
    "no_rows.csv": ("t,x,y\n", r"holds no samples"),
    "empty.csv": ("\n\n", r"the file is empty"),
    "text.csv": ("t,x,y\n0,0.1,zero\n", r"line 2: column 'y' is not a number: 'zero'"),
    "missing_t.csv": ("t,x,y\n0,0.1,0.1\n,0.2,0.2\n", r"line 3: missing or non-numeric timestamp"),
    "extra.csv": ("t,x,y\n0,0.1,0.1,0.9\n", r"line 2: 4 cells but the header names 3 columns"),
    "no_unit.tsv": ("Recording timestamp\tGaze point X\tGaze point Y\n0\t1\t1\n", r"has no unit"),
    "bad_unit.tsv": (
        "Recording timestamp [min]\tGaze point X\tGaze point Y\n0\t1\t1\n",
        r"unknown timestamp unit \[min\]",
    ),
    "no_eye.tsv": (
        "Recording timestamp [ms]\tSensor\tGaze point X\tGaze point Y\n0\tGyroscope\t\t\n",
        r"no rows with Sensor = 'Eye Tracker'",
    ),
    "on_surf.csv": (
        "gaze_timestamp,x_norm,y_norm,on_surf\n0,0.5,0.5,maybe\n",
        r"line 2: on_surf must be True or False",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_trace_names_file_and_problem(tmp_path: Path, name: str) -> None:
    text, problem = CASES[name]
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(GazeError, match=problem) as info:
        read_trace(path, screen_px=(1920, 1080))
    assert info.value.where == str(path)
    assert str(info.value).startswith(f"{path}: ")


def test_unreadable_files(tmp_path: Path) -> None:
    missing = tmp_path / "nope.csv"
    with pytest.raises(GazeError, match=r"nope\.csv: trace file not found"):
        read_trace(missing)
    with pytest.raises(GazeError, match=r": not a file"):
        read_trace(tmp_path)
    binary = tmp_path / "image.csv"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe\x00")
    with pytest.raises(GazeError, match=r"image\.csv: not a UTF-8 text file"):
        read_trace(binary)
    zeros = tmp_path / "zeros.csv"
    zeros.write_bytes(b"t,x,y\n\x00\x00\x00\n")
    with pytest.raises(GazeError, match=r"zeros\.csv: not a text file"):
        read_trace(zeros)


def test_bad_screen_size(tmp_path: Path) -> None:
    path = tmp_path / "px.csv"
    path.write_text("t,x,y\n0,960,540\n", encoding="utf-8")
    with pytest.raises(GazeError, match=r"px\.csv: screen size must be positive"):
        read_trace(path, screen_px=(0, 1080))
