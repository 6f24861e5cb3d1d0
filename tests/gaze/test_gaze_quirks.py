"""The quirks of real exports, each on a small hand-written fixture with its one defined behaviour."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from trace_fixtures import FIXTURES, GAZEPOINT, TOBII_PRO_LAB, tsv

from gaze.errors import GazeError
from gaze.trace.columns import split_unit
from gaze.trace.detect import detect_format, read_trace
from gaze.trace.playback import TraceSource


def write(folder: Path, name: str, text: str, encoding: str = "utf-8") -> Path:
    """Write a fixture file and return its path."""
    path = folder / name
    path.write_bytes(text.encode(encoding))
    return path


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])
@pytest.mark.parametrize("key", ["tobii", "gazepoint", "eyelink", "tobii_sdk"])
def test_byte_order_mark_is_dropped(tmp_path: Path, key: str, encoding: str) -> None:
    fixture = FIXTURES[key]
    path = fixture.write(tmp_path, encoding)
    assert detect_format(path) == fixture.fmt
    data = read_trace(path, screen_px=fixture.screen_px)
    np.testing.assert_allclose(data.x[data.valid], fixture.x)


@pytest.mark.parametrize("ending", ["\r\n", "\r"])
def test_crlf_and_cr_line_endings(tmp_path: Path, ending: str) -> None:
    path = write(tmp_path, "all_gaze.csv", GAZEPOINT.replace("\n", ending))
    data = read_trace(path)
    np.testing.assert_allclose(data.t, FIXTURES["gazepoint"].t)
    np.testing.assert_allclose(data.y[data.valid], FIXTURES["gazepoint"].y)


def test_leading_blank_lines_keep_line_numbers(tmp_path: Path) -> None:
    text = "\n  \n" + "gaze_timestamp,confidence,norm_pos_x,norm_pos_y\n1.0,0.9,0.5,0.5\n1.0,0.9,0.6,0.6\n"
    path = write(tmp_path, "gaze_positions.csv", text)
    assert detect_format(path) == "pupil"
    with pytest.raises(GazeError, match=r"line 5: duplicate timestamp"):
        read_trace(path)


def test_last_row_cut_off_mid_field_is_skipped(tmp_path: Path) -> None:
    path = write(tmp_path, "trace.csv", "t,x,y,confidence\n0,0.1,0.2,1\n0.5,0.3,0.4,1\n1.0,0.5")
    data = read_trace(path)
    np.testing.assert_allclose(data.t, [0.0, 0.5])
    assert dict(data.skipped) == {"last row cut off": 1}
    # a complete last row without a line break is a sample
    whole = write(tmp_path, "whole.csv", "t,x,y\n0,0.1,0.2\n0.5,0.3,0.4")
    assert len(read_trace(whole)) == 2 and not read_trace(whole).skipped
    # the same in an ASC file: the unterminated short sample line is dropped
    asc = FIXTURES["eyelink"].text.rsplit("END", 1)[0] + "1000010\t 12"
    data = read_trace(write(tmp_path, "cut.asc", asc))
    assert len(data) == 4 and data.skipped["last row cut off"] == 1


def test_decimal_commas_with_semicolons(tmp_path: Path) -> None:
    text = "TIME(2024/01/15 10:00:00.000);FPOGX;FPOGY;FPOGV;\n0,000;0,5;0,25;1;\n0,0166;0,75;0,5;1;\n"
    path = write(tmp_path, "all_gaze.csv", text)
    assert detect_format(path) == "gazepoint"
    data = read_trace(path)
    np.testing.assert_allclose(data.t, [0.0, 0.0166])
    np.testing.assert_allclose(np.c_[data.x, data.y], [[0.5, 0.25], [0.75, 0.5]])


def test_semicolon_simple_csv(tmp_path: Path) -> None:
    data = read_trace(write(tmp_path, "trace.csv", "t;x;y\n0;0,1;0,2\n0,5;0,3;0,4\n"))
    np.testing.assert_allclose(np.c_[data.t, data.x, data.y], [[0.0, 0.1, 0.2], [0.5, 0.3, 0.4]])


def test_trailing_delimiters(tmp_path: Path) -> None:
    data = read_trace(write(tmp_path, "trace.csv", "t,x,y,\n0,0.1,0.2,\n0.5,0.3,0.4,\n"))
    np.testing.assert_allclose(data.x, [0.1, 0.3])
    tobii = write(tmp_path, "export.tsv", TOBII_PRO_LAB.replace("\n", "\t\n"))
    assert detect_format(tobii) == "tobii" and len(read_trace(tobii)) == 2


@pytest.mark.parametrize(
    ("label", "expected"),
    [
        ("Recording timestamp [ms]", ("recording timestamp", "ms")),
        ("timestamp [ns]", ("timestamp", "ns")),
        ("Recording timestamp [μs]", ("recording timestamp", "μs")),
        ("gaze x [px]", ("gaze x", "px")),
        ("GazePointX (ADCSpx)", ("gazepointx", "ADCSpx")),
        ("TIME(2024/01/15 10:00:00.000)", ("time", "2024/01/15 10:00:00.000")),
        ("norm_pos_x", ("norm_pos_x", None)),
    ],
)
def test_units_in_headers_parsed_in_one_place(label: str, expected: tuple[str, str | None]) -> None:
    assert split_unit(label) == expected


@pytest.mark.parametrize(
    ("unit", "scale"), [("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("µs", 1e-6), ("μs", 1e-6), ("ns", 1e-9)]
)
def test_time_units_in_headers(tmp_path: Path, unit: str, scale: float) -> None:
    text = tsv(
        f"Recording timestamp [{unit}]|Gaze point X [DACS px]|Gaze point Y [DACS px]", "1000|10|20", "3000|30|40"
    )
    data = read_trace(write(tmp_path, "export.tsv", text), screen_px=(100, 100))
    np.testing.assert_allclose(data.t, [0.0, 2000 * scale], rtol=1e-12)
    simple = write(tmp_path, "trace.csv", f"t [{unit}],x [px],y [px]\n1000,10,20\n3000,30,40\n")
    data = read_trace(simple, screen_px=(100, 200))
    np.testing.assert_allclose(np.c_[data.t, data.x, data.y], [[0, 0.1, 0.1], [2000 * scale, 0.3, 0.2]], rtol=1e-12)


def test_pixel_units_need_a_screen(tmp_path: Path) -> None:
    with pytest.raises(GazeError, match=r"trace\.csv: gaze points are pixels of the screen but there is no screen"):
        read_trace(write(tmp_path, "trace.csv", "t,x [px],y [px]\n0,10,20\n"))


def test_mouse_and_event_rows_are_skipped_and_counted(tmp_path: Path) -> None:
    text = tsv(
        "Recording timestamp [ms]|Sensor|Event|Gaze point X|Gaze point Y",
        "0|Eye Tracker||960|540",
        "0||ImageStimulusStart||",
        "5|Mouse|||",
        "8|Eye Tracker||480|270",
        "8|Mouse|||",
    )
    data = read_trace(write(tmp_path, "export.tsv", text), screen_px=(1920, 1080))
    np.testing.assert_allclose(np.c_[data.t, data.x, data.y], [[0.0, 0.5, 0.5], [0.008, 0.25, 0.25]])
    assert dict(data.skipped) == {"Sensor is not 'Eye Tracker' (mouse, gyroscope, event rows)": 3}
    studio = read_trace(FIXTURES["tobii_studio"].write(tmp_path / "studio"))
    assert studio.skipped == {"event rows (no validity codes: mouse and Studio events)": 2}


def test_binocular_and_monocular_rows_interleaved(tmp_path: Path) -> None:
    text = (
        "gaze_timestamp,world_index,confidence,norm_pos_x,norm_pos_y,base_data\n"
        "10.000,0,0.99,0.5,0.5,9.998-0 10.002-1\n"
        "10.001,0,0.90,0.9,0.9,10.001-1\n"
        "10.004,0,0.99,0.25,0.75,10.003-0 10.005-1\n"
        "10.004,0,0.90,0.1,0.1,10.004-0\n"
        "10.003,0,0.90,0.2,0.2,10.003-0\n"
        "10.008,1,0.99,0.75,0.25,10.007-0 10.009-1\n"
    )
    data = read_trace(write(tmp_path, "gaze_positions.csv", text))
    np.testing.assert_allclose(data.t, [0.0, 0.004, 0.008], atol=1e-9)
    np.testing.assert_allclose(np.c_[data.x, data.y], [[0.5, 0.5], [0.25, 0.25], [0.75, 0.75]])
    assert dict(data.skipped) == {"monocular rows among binocular ones": 3}
    # a monocular-only file (one eye camera) keeps every row
    mono = text.replace(" 10.002-1", "").replace(" 10.005-1", "").replace(" 10.009-1", "")
    mono = "\n".join(line for line in mono.splitlines() if not line.startswith(("10.001", "10.003", "10.004,0,0.90")))
    assert len(read_trace(write(tmp_path, "mono.csv", mono + "\n"))) == 3
    # EyeLink: a binocular block then a monocular one (fixture eyelink_mixed)
    mixed = FIXTURES["eyelink_mixed"]
    np.testing.assert_allclose(read_trace(mixed.write(tmp_path / "asc")).x[[0, 3]], [0.5, 0.1])


@pytest.mark.parametrize(
    ("key", "reason"),
    [
        ("gazepoint", "flagged invalid (FPOGV 0)"),
        ("tobii_studio", "validity code 2-4 on both eyes"),
        ("tobii", "both eyes Invalid"),
        ("tobii_sdk", "neither eye valid"),
        ("marker_mapper", "off the surface"),
        ("pupil_surface", "off the surface (on_surf False)"),
    ],
)
def test_rows_flagged_invalid_that_carry_coordinates(tmp_path: Path, key: str, reason: str) -> None:
    """The flag wins: the sample is invalid, its coordinates are dropped, the reason is counted."""
    fixture = FIXTURES[key]
    data = read_trace(fixture.write(tmp_path), screen_px=fixture.screen_px)
    assert data.invalid[reason] >= 1
    assert np.isnan(data.x[~data.valid]).all()
    source = TraceSource(data)
    first_flagged = int(np.argmax(~data.valid))
    held = source.sample(float(data.t[first_flagged]))
    assert not held.valid and held.confidence == 0.0  # playback holds the last valid fixation


def test_timestamps_jumping_back_without_a_recording_column_name_the_line(tmp_path: Path) -> None:
    text = "system_time_stamp;left_gaze_point_on_display_area\n100;(0.1, 0.1)\n200;(0.2, 0.2)\n50;(0.3, 0.3)\n"
    with pytest.raises(GazeError, match=r"dump\.csv: line 4: timestamp .* is before the previous one"):
        read_trace(write(tmp_path, "dump.csv", text))


def test_outliers_far_outside_the_screen_are_invalid(tmp_path: Path) -> None:
    text = tsv(
        "Recording timestamp [ms]|Gaze point X|Gaze point Y",
        "0|960|540",
        "10|-5000|540",
        "20|2100|1150",
        "30|960|9000",
        "40|480|270",
    )
    data = read_trace(write(tmp_path, "export.tsv", text), screen_px=(1920, 1080))
    np.testing.assert_array_equal(data.valid, [True, False, True, False, True])
    assert dict(data.invalid) == {"outside the screen": 2}
    # a point just beyond the edge is kept, and playback clamps it to the edge
    s = TraceSource(data).sample(0.02)
    assert s.valid and (s.x, s.y) == (1.0, 1.0)
