"""Trace readers on small handmade fixtures: simple CSV, Pupil Labs, Tobii; detection; round trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gaze.errors import GazeError
from gaze.trace.detect import detect_format, read_trace
from gaze.trace.simple_csv import read_simple, write_simple, write_trace

SIMPLE = """t,x,y,confidence
10.0,0.1,0.2,1
10.5,0.3,0.4,0.9
11.0,,,0
11.5,0.5,0.6,0.5
12.0,0.7,0.8,
"""

PUPIL_GAZE = """gaze_timestamp,world_index,confidence,norm_pos_x,norm_pos_y,base_data
5000.25,0,0.99,0.5,0.2,100.1-0
5000.35,0,0.95,0.25,0.75,100.2-0
5000.45,1,0.30,0.6,0.6,100.3-0
5000.55,1,0.90,1.0,0.0,100.4-0
"""

PUPIL_SURFACE = """world_timestamp,world_index,gaze_timestamp,x_norm,y_norm,x_scaled,y_scaled,on_surf,confidence
7.0,0,7.00,0.5,0.2,960,216,True,0.98
7.0,0,7.01,0.1,0.9,192,972,True,0.97
7.1,1,7.02,1.3,0.5,2496,540,False,0.99
7.1,1,7.03,0.75,0.25,1440,270,True,0.96
"""

TOBII_US = (
    "Recording timestamp [μs]\tSensor\tGaze point X [DACS px]\tGaze point Y [DACS px]\t"
    "Recording resolution width\tRecording resolution height\n"
    "1000000\tEye Tracker\t960\t270\t1920\t1080\n"
    "1000000\tGyroscope\t\t\t1920\t1080\n"
    "1016667\tEye Tracker\t480\t810\t1920\t1080\n"
    "1020000\tAccelerometer\t\t\t1920\t1080\n"
    "1033333\tEye Tracker\t\t\t1920\t1080\n"
    "1050000\tEye Tracker\t1920\t1080\t1920\t1080\n"
)

TOBII_MS = (
    "Participant name\tRecording timestamp [ms]\tGaze point X\tGaze point Y\n"
    "P1\t250\t100\t50\n"
    "P1\t266,5\t300\t150\n"
    "P1\t283\t\t150\n"
)


def write(folder: Path, name: str, text: str) -> Path:
    """Write a fixture file and return its path."""
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def test_simple_normalised(tmp_path: Path) -> None:
    data = read_trace(write(tmp_path, "trace.csv", SIMPLE))
    assert data.format == "simple"
    np.testing.assert_allclose(data.t, [0.0, 0.5, 1.0, 1.5, 2.0])
    np.testing.assert_array_equal(data.valid, [True, True, False, False, True])
    np.testing.assert_allclose(data.x[data.valid], [0.1, 0.3, 0.7])
    np.testing.assert_allclose(data.y[data.valid], [0.2, 0.4, 0.8])
    # an empty confidence cell means 1; invalid rows carry no measurement
    np.testing.assert_allclose(data.confidence, [1.0, 0.9, 0.0, 0.0, 1.0])
    assert np.isnan(data.x[~data.valid]).all()


def test_simple_pixels_with_screen(tmp_path: Path) -> None:
    path = write(tmp_path, "px.csv", "t,x,y\n0,960,540\n0.1,0,1080\n0.2,480,270\n")
    data = read_simple(path, screen_px=(1920, 1080))
    np.testing.assert_allclose(data.x, [0.5, 0.0, 0.25])
    np.testing.assert_allclose(data.y, [0.5, 1.0, 0.25])
    np.testing.assert_allclose(data.confidence, 1.0)
    with pytest.raises(GazeError, match=r"px\.csv.*look like pixels"):
        read_simple(path)


def test_pupil_gaze_positions_flips_y(tmp_path: Path) -> None:
    path = write(tmp_path, "gaze_positions.csv", PUPIL_GAZE)
    assert detect_format(path) == "pupil"
    data = read_trace(path)
    np.testing.assert_allclose(data.t, [0.0, 0.1, 0.2, 0.3], atol=1e-9)
    np.testing.assert_array_equal(data.valid, [True, True, False, True])  # confidence 0.3 < 0.6
    np.testing.assert_allclose(data.x[data.valid], [0.5, 0.25, 1.0])
    np.testing.assert_allclose(data.y[data.valid], [0.8, 0.25, 1.0])  # bottom-left origin flipped
    np.testing.assert_allclose(data.confidence, [0.99, 0.95, 0.0, 0.90])
    lenient = read_trace(path, min_confidence=0.2)
    assert lenient.valid.all()
    np.testing.assert_allclose(lenient.y[2], 0.4)


def test_pupil_surface_flips_y_and_drops_off_surface(tmp_path: Path) -> None:
    path = write(tmp_path, "gaze_positions_on_surface_Screen.csv", PUPIL_SURFACE)
    assert detect_format(path) == "pupil_surface"
    data = read_trace(path)
    np.testing.assert_allclose(data.t, [0.0, 0.01, 0.02, 0.03], atol=1e-9)
    np.testing.assert_array_equal(data.valid, [True, True, False, True])
    np.testing.assert_allclose(data.x[data.valid], [0.5, 0.1, 0.75])
    np.testing.assert_allclose(data.y[data.valid], [0.8, 0.1, 0.75])


def test_tobii_microseconds_with_sensor_rows(tmp_path: Path) -> None:
    path = write(tmp_path, "export.tsv", TOBII_US)
    assert detect_format(path) == "tobii"
    data = read_trace(path)
    # the Gyroscope row shares a timestamp with an eye tracker row: dropped before validation
    assert len(data) == 4
    np.testing.assert_allclose(data.t, [0.0, 0.016667, 0.033333, 0.05], atol=1e-12)
    np.testing.assert_array_equal(data.valid, [True, True, False, True])
    np.testing.assert_allclose(data.x[data.valid], [0.5, 0.25, 1.0])
    np.testing.assert_allclose(data.y[data.valid], [0.25, 0.75, 1.0])


def test_tobii_milliseconds_screen_from_caller(tmp_path: Path) -> None:
    path = write(tmp_path, "export_ms.tsv", TOBII_MS)
    data = read_trace(path, screen_px=(400, 300))
    np.testing.assert_allclose(data.t, [0.0, 0.0165, 0.033])  # decimal comma accepted
    np.testing.assert_array_equal(data.valid, [True, True, False])
    np.testing.assert_allclose(data.x[:2], [0.25, 0.75])
    np.testing.assert_allclose(data.y[:2], [1 / 6, 0.5])
    with pytest.raises(GazeError, match=r"export_ms\.tsv.*no screen size"):
        read_trace(path)


def test_format_override(tmp_path: Path) -> None:
    surface = write(tmp_path, "surface.csv", PUPIL_SURFACE)
    simple = write(tmp_path, "simple.csv", SIMPLE)
    assert read_trace(surface, "pupil_surface").format == "pupil_surface"
    # the override picks the reader, whatever the header says
    with pytest.raises(GazeError, match=r"surface\.csv.*missing column 'norm_pos_x'"):
        read_trace(surface, "pupil")
    with pytest.raises(GazeError, match=r"simple\.csv.*missing column 'recording timestamp'"):
        read_trace(simple, "tobii")
    with pytest.raises(GazeError, match=r"simple\.csv.*unknown trace format 'xml'"):
        read_trace(simple, "xml")


@pytest.mark.parametrize("screen_px", [None, (1920, 1080)])
def test_simple_round_trip(tmp_path: Path, screen_px: tuple[int, int] | None) -> None:
    original = read_trace(write(tmp_path, "gaze_positions.csv", PUPIL_GAZE))
    out = tmp_path / "out.csv"
    write_trace(out, original, screen_px)
    assert out.read_text().splitlines()[0] == "t,x,y,confidence"
    again = read_trace(out, screen_px=screen_px)
    np.testing.assert_allclose(again.t, original.t, atol=1e-6)
    np.testing.assert_array_equal(again.valid, original.valid)
    tol = 1e-6 if screen_px is None else 0.006 / 1080
    np.testing.assert_allclose(again.x[again.valid], original.x[original.valid], atol=tol)
    np.testing.assert_allclose(again.y[again.valid], original.y[original.valid], atol=tol)
    np.testing.assert_allclose(again.confidence, original.confidence, atol=1e-4)


def test_writer_refuses_what_it_could_not_read_back(tmp_path: Path) -> None:
    out = tmp_path / "bad.csv"
    ones = np.ones(3)
    with pytest.raises(GazeError, match=r"bad\.csv.*strictly increasing"):
        write_simple(out, np.array([0.0, 0.2, 0.1]), ones, ones, ones, ones.astype(bool))
    with pytest.raises(GazeError, match=r"bad\.csv.*valid sample 1"):
        write_simple(out, np.arange(3.0), np.array([0.1, np.nan, 0.2]), ones, ones, ones.astype(bool))
    assert list(tmp_path.iterdir()) == []
    write_simple(tmp_path / "missing" / "x.csv", np.arange(3.0), ones, ones, ones, ones.astype(bool))
    assert [p.name for p in (tmp_path / "missing").iterdir()] == ["x.csv"]  # one rule: missing folders are made
