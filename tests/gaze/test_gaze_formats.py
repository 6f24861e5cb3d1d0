"""Every supported trace format on its hand-written fixture: the expected samples, and detection
that picks the right reader for every fixture and never mistakes one format for another."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from trace_fixtures import FIXTURES, NEON, Fixture

from gaze.errors import GazeError
from gaze.trace.detect import FORMATS, READERS, detect_format, matching_readers, read_recordings, read_trace
from gaze.trace.table import open_text
from gaze.trace.text import TraceText


def assert_reads_as(path: Path, fixture: Fixture, **options: object) -> None:
    """Read ``path`` and compare it with what ``fixture`` expects."""
    data = read_trace(path, screen_px=fixture.screen_px, **options)  # type: ignore[arg-type]
    assert data.format == fixture.fmt
    assert data.recording == fixture.recording
    np.testing.assert_allclose(data.t, fixture.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(data.valid, fixture.valid)
    np.testing.assert_allclose(data.x[data.valid], fixture.x, atol=1e-12)
    np.testing.assert_allclose(data.y[data.valid], fixture.y, atol=1e-12)
    assert np.isnan(data.x[~data.valid]).all() and (data.confidence[~data.valid] == 0).all()
    assert dict(data.invalid) == fixture.invalid
    assert dict(data.skipped) == fixture.skipped


@pytest.mark.parametrize("key", sorted(FIXTURES))
def test_fixture_reads_as_expected(tmp_path: Path, key: str) -> None:
    fixture = FIXTURES[key]
    assert_reads_as(fixture.write(tmp_path / key), fixture)


@pytest.mark.parametrize("key", sorted(FIXTURES))
def test_detection_picks_exactly_one_reader(tmp_path: Path, key: str) -> None:
    fixture = FIXTURES[key]
    path = fixture.write(tmp_path / key)
    text = TraceText(str(path), open_text(path))
    assert [reader.name for reader in matching_readers(text)] == [fixture.fmt]
    assert detect_format(path) == fixture.fmt


def test_every_format_has_a_fixture_and_a_title() -> None:
    assert {f.fmt for f in FIXTURES.values()} == set(FORMATS)
    assert len(set(FORMATS)) == len(FORMATS) == len(READERS)
    assert all(reader.title and reader.expects for reader in READERS)


@pytest.mark.parametrize("key", sorted(FIXTURES))
def test_another_formats_reader_refuses_with_a_clear_error(tmp_path: Path, key: str) -> None:
    """Forcing a wrong format never reads a fixture silently: it is a GazeError naming the file."""
    fixture = FIXTURES[key]
    path = fixture.write(tmp_path / key)
    for fmt in FORMATS:
        if fmt == fixture.fmt:
            continue
        try:
            data = read_trace(path, fmt, screen_px=(1000, 1000))
        except GazeError as exc:
            assert exc.where == str(path)
        else:  # a reader may only accept another format's file when the columns are its own
            pytest.fail(f"{fmt} read the {fixture.fmt} fixture {key} as {len(data)} samples")


def test_pupil_cloud_timestamps_are_int64_nanoseconds(tmp_path: Path) -> None:
    # 1.7e18 ns does not fit a float: 1 ns steps only survive as integers
    text = NEON.replace("1700000000005000000", "1700000000000000001")
    fixture = FIXTURES["neon"]
    path = tmp_path / "gaze.csv"
    path.write_text(text, encoding="utf-8")
    (tmp_path / "info.json").write_text(fixture.siblings["info.json"], encoding="utf-8")
    data = read_trace(path)
    assert data.t[1] == pytest.approx(1e-9, rel=1e-6)
    assert data.t[2] == pytest.approx(0.010000001, abs=1e-15)


def test_pupil_cloud_device_decides_the_camera_size(tmp_path: Path) -> None:
    fixture = FIXTURES["neon"]
    bare = tmp_path / "gaze.csv"
    bare.write_text(fixture.text, encoding="utf-8")
    with pytest.raises(
        GazeError, match=r"gaze\.csv: .*scene camera.*--screen 1600x1200 \(Neon\) or --screen 1088x1080"
    ):
        read_trace(bare)
    # the caller's size needs no info.json, and overrides the device's
    np.testing.assert_allclose(read_trace(bare, screen_px=(800, 600)).x[:2], [1.0, 0.5])
    data = read_recordings(fixture.write(tmp_path / "neon")).trace()
    assert data.notes["pixels"] == "1600x1200 (the scene camera image; Neon, from info.json beside the file)"


def test_reference_image_mapper_needs_the_image_size(tmp_path: Path) -> None:
    fixture = FIXTURES["reference_image_mapper"]
    path = fixture.write(tmp_path)
    with pytest.raises(GazeError, match=r"pixels of the reference image .*give the reference image's --screen WxH"):
        read_trace(path)


def test_imotions_without_info_needs_the_camera_size(tmp_path: Path) -> None:
    fixture = FIXTURES["pupil_imotions"]
    path = tmp_path / "gaze.tlv"
    path.write_text(fixture.text, encoding="utf-8")
    with pytest.raises(GazeError, match=r"gaze\.tlv: .*undistorted world camera.*iMotions_info\.csv"):
        read_trace(path)
    np.testing.assert_allclose(read_trace(path, screen_px=(640, 360)).x[:2], [1.0, 0.5])


def test_eyelink_screen_from_display_coords_or_caller(tmp_path: Path) -> None:
    fixture = FIXTURES["eyelink"]
    path = fixture.write(tmp_path)
    assert read_trace(path).notes["pixels"] == "1280x1024 (the display; DISPLAY_COORDS message)"
    np.testing.assert_allclose(read_trace(path, screen_px=(640, 512)).x[:2], [1.0, 0.5])
    no_display = fixture.text.replace("DISPLAY_COORDS", "DISPLAY_NOTE")
    gaze_coords = tmp_path / "gaze_coords.asc"
    gaze_coords.write_text(no_display, encoding="utf-8")
    np.testing.assert_allclose(read_trace(gaze_coords).x[:2], [640 / 1920, 320 / 1920])  # GAZE_COORDS, 1920 wide
    neither = tmp_path / "neither.asc"
    neither.write_text(no_display.replace("GAZE_COORDS", "GAZE_NOTE"), encoding="utf-8")
    with pytest.raises(GazeError, match=r"neither\.asc: gaze points are pixels of the display but there is no screen"):
        read_trace(neither)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("** CONVERTED\n1000\t1.0\t2.0\t3.0\t...\n", r"line 2: a sample before any 'SAMPLES GAZE"),
        ("** CONVERTED\nSAMPLES\tHREF\tLEFT\tRATE\t500\n1000\t1\t2\t3\n", r"line 2: the samples are not screen gaze"),
        ("** C\nSAMPLES\tGAZE\tLEFT\tRIGHT\n1000\t1\t2\t3\t4\n1001\t1\t2\t3\t4\t5\t6\n", r"line 3: a binocular .*7"),
        ("** C\nSAMPLES\tGAZE\tLEFT\n1000\tx\t2\t3\n", r"line 3: not a sample"),
        ("** C\nMSG\t1 DISPLAY_COORDS 0 0 wide 1079\n", r"line 2: DISPLAY_COORDS needs four numbers"),
        ("** C\nMSG\t1 DISPLAY_COORDS 0 0 1919 1079\n", r"no sample lines"),
    ],
)
def test_eyelink_bad_input(tmp_path: Path, text: str, problem: str) -> None:
    path = tmp_path / "bad.asc"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(GazeError, match=problem) as info:
        read_trace(path, screen_px=(1920, 1080))
    assert info.value.where == str(path)


def test_tobii_sdk_malformed_tuple_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "dump.csv"
    path.write_text(
        "system_time_stamp;left_gaze_point_on_display_area;left_gaze_point_validity\n1;(0.5, 0.5);1\n2;(0.5);1\n",
        encoding="utf-8",
    )
    with pytest.raises(GazeError, match=r"line 3: column 'left_gaze_point_on_display_area' is not an \(x, y\) pair"):
        read_trace(path)


def test_unknown_columns_lists_every_format(tmp_path: Path) -> None:
    path = tmp_path / "mystery.csv"
    path.write_text("when,where\n1,2\n", encoding="utf-8")
    with pytest.raises(GazeError, match=r"unknown columns \['when', 'where'\]; expected one of") as info:
        read_trace(path)
    assert all(reader.title in info.value.problem for reader in READERS)
