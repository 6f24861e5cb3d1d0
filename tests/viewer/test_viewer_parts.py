"""The viewer's parts without a server: the protocol, navigation, timeline, hub, recorder, calibration."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import numpy as np
import pytest

from gaze.source import GazeSample
from gaze.webcam.calibration import load_calibration
from warp_hybrid.scene.model import Camera
from warp_hybrid.viewer.calibration import CalibrationSession
from warp_hybrid.viewer.gaze_feed import PointerGaze, webcam_spec
from warp_hybrid.viewer.hub import FrameHub
from warp_hybrid.viewer.navigation import Navigator
from warp_hybrid.viewer.protocol import (
    CLIENT_MESSAGES,
    ProtocolError,
    pack_frame,
    parse_client_message,
    schema_document,
    unpack_frame,
)
from warp_hybrid.viewer.recorder import Recorder
from warp_hybrid.viewer.server import STATIC_DIR, static_files
from warp_hybrid.viewer.timeline import Timeline


def _msg(message_type: str, /, **fields: object) -> str:
    return json.dumps({"v": 1, "type": message_type, **fields})


def test_a_valid_message_parses_to_typed_fields() -> None:
    m = parse_client_message(_msg("pointer", x=0, y=1, seq=3.0, sent_ms=12.5))
    assert m.type == "pointer" and m.fields == {"x": 0.0, "y": 1.0, "seq": 3, "sent_ms": 12.5}
    assert isinstance(m.fields["seq"], int)
    assert parse_client_message(_msg("control", mode="full")).fields == {"mode": "full"}
    assert parse_client_message(_msg("reset_view")).fields == {}


@pytest.mark.parametrize(
    "text",
    [
        b"\xff\xfe",
        "null",
        _msg("pointer", x=0.5, y=-0.01, seq=0, sent_ms=0),
        _msg("pointer", x=0.5, y=0.5, seq=-1, sent_ms=0),
        _msg("navigate", kind="orbit", dx=5.0, dy=0.0),
        _msg("navigate", kind="spin", dx=0.0, dy=0.0),
        _msg("reset_view", now=True),
        _msg("camera", name=7),
        " " * 5000,
    ],
)
def test_malformed_messages_are_refused(text: str | bytes) -> None:
    with pytest.raises(ProtocolError):
        parse_client_message(text)


def test_the_page_documentation_is_the_validation_table() -> None:
    doc = schema_document()
    assert set(doc["messages"]) == set(CLIENT_MESSAGES)
    fps = next(f for f in doc["messages"]["control"]["fields"] if f["name"] == "fps")
    assert (fps["min"], fps["max"], fps["required"]) == (1.0, 240.0, False)
    parse_client_message(_msg("control", fps=fps["max"]))
    with pytest.raises(ProtocolError):
        parse_client_message(_msg("control", fps=fps["max"] + 1))


def test_a_frame_message_round_trips() -> None:
    header, jpeg = unpack_frame(pack_frame({"index": 4, "gaze": {"x": 0.5}}, b"\xff\xd8jpeg"))
    assert header == {"v": 1, "type": "frame", "index": 4, "gaze": {"x": 0.5}} and jpeg == b"\xff\xd8jpeg"
    with pytest.raises(ValueError):
        pack_frame({"bad": math.nan}, b"")


def test_static_files_are_only_the_folder_s_own() -> None:
    files = static_files()
    assert {"index.html", "viewer.js", "viewer.css", "calibrate.html", "calibrate.js"} <= set(files)
    assert all(p.parent == STATIC_DIR for p in files.values())


def test_the_page_loads_nothing_from_the_network() -> None:
    for path in STATIC_DIR.iterdir():
        text = path.read_text(encoding="utf-8")
        assert "http://" not in text and "https://" not in text and "@import" not in text, path.name


def _camera() -> Camera:
    c2w = np.eye(4)
    c2w[:3, 3] = (0.0, 1.0, 5.0)  # looking down -Z at the origin's depth 5
    return Camera("cam", c2w)


def test_orbit_keeps_the_pivot_distance_and_a_full_turn_comes_back() -> None:
    nav = Navigator(_camera(), np.array([0.0, 1.0, 0.0]))
    start = nav.camera().cam_to_world
    np.testing.assert_allclose(start, _camera().cam_to_world, atol=1e-12)
    nav.orbit(0.5, 0.0)  # half a frame width: a quarter turn
    quarter = nav.camera()
    assert np.linalg.norm(quarter.position - np.array([0.0, 1.0, 0.0])) == pytest.approx(5.0)
    assert abs(quarter.forward[0]) == pytest.approx(1.0)
    nav.orbit(1.5, 0.0)
    np.testing.assert_allclose(nav.camera().cam_to_world, start, atol=1e-9)
    nav.orbit(0.0, 10.0)  # pitch stops short of the pole
    assert abs(nav.camera().forward[1]) < math.sin(math.radians(89.5))
    r = nav.camera().cam_to_world[:3, :3]
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)


def test_pan_slides_sideways_and_zoom_moves_towards_the_pivot() -> None:
    nav = Navigator(_camera(), np.array([0.0, 1.0, 0.0]))
    nav.pan(0.1, 0.0, aspect=4 / 3)
    moved = nav.camera()
    width = 2 * 5.0 * _camera().tan_half_fov_x
    np.testing.assert_allclose(moved.position, [-0.1 * width, 1.0, 5.0], atol=1e-12)
    np.testing.assert_allclose(moved.forward, [0.0, 0.0, -1.0], atol=1e-12)
    nav.zoom(-0.5)
    assert nav.distance == pytest.approx(5.0 * math.exp(-1.0))


def test_the_timeline_plays_loops_pauses_and_seeks() -> None:
    line = Timeline(2.0, now=10.0)
    assert line.playing and line.time(10.5) == pytest.approx(0.5)
    assert line.time(12.25) == pytest.approx(0.25)  # looped
    line.play(False, 12.25)
    assert line.time(20.0) == pytest.approx(0.25)
    line.seek(5.0, 20.0)
    assert line.time(21.0) == 2.0  # clamped, paused
    still = Timeline(0.0, now=0.0)
    still.play(True, 1.0)
    assert not still.playing and still.time(5.0) == 0.0


def test_the_hub_keeps_only_the_newest_frame_and_never_blocks_the_publisher() -> None:
    async def run() -> tuple[int, int | None, list[int]]:
        hub = FrameHub()
        hub.bind(asyncio.get_running_loop())
        client = hub.connect()
        for i in range(100):
            hub.publish(b"frame %d" % i)
        await asyncio.sleep(0)
        latest = hub.latest()
        hub.send_event({"name": "x"}, client.id)
        hub.send_event({"name": "y"}, client.id + 1)  # another page: not this one's
        await asyncio.sleep(0)
        return hub.published, latest[0] if latest else None, [len(client.events), client.wakeup.is_set()]

    published, newest, (events, woken) = asyncio.run(run())
    assert (published, newest, events, woken) == (100, 99, 1, True)
    FrameHub().publish(b"no loop bound")  # nothing to wake: fine


def test_the_pointer_feed_says_which_message_set_the_gaze() -> None:
    feed = PointerGaze()
    sample, tag = feed.sample(0.0)
    assert tag is None and not sample.valid and (sample.x, sample.y) == (0.5, 0.5)
    feed.pointer(3, 0.2, 0.9, 41, 1234.5)
    sample, tag = feed.sample(1.0)
    assert (sample.x, sample.y, sample.valid) == (0.2, 0.9, True)
    assert tag is not None and (tag.client, tag.seq, tag.sent_ms) == (3, 41, 1234.5)
    assert webcam_spec("webcam:0?calibration=c.json") == "webcam:0" and webcam_spec("cursor") is None


def test_a_recording_with_no_valid_gaze_is_refused(tmp_path: Path) -> None:
    recorder = Recorder(tmp_path, "scene.usda")
    recorder.start(0.0, 0.0)
    recorder.add(0.1, GazeSample(0.5, 0.5, 0.1, confidence=0.0, valid=False), _camera())
    with pytest.raises(ValueError, match="nothing to save"):
        recorder.stop(15.0, None)
    assert not recorder.recording and not tmp_path.joinpath("recordings").exists()


def test_calibration_fits_the_nine_targets_and_saves_a_file_the_estimator_loads(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    session = CalibrationSession(start=100.0, dwell_s=0.5)
    shown = []
    now, frame = 100.0, 0
    while not session.done(now):
        target = session.schedule.index_at(np.array([now]))[0]
        tx, ty = session.schedule.x[target], session.schedule.y[target]
        feature = (0.3 * (tx - 0.5) + 0.02 * ty + rng.normal(0, 1e-4), -0.2 * (ty - 0.5) + rng.normal(0, 1e-4))
        step = session.collect(now, GazeSample(0.5, 0.5, frame / 30.0, 0.0, False, features=feature))
        if step is not None:
            shown.append((step.index, step.x, step.y))
        now, frame = now + 1 / 30.0, frame + 1
    assert [s[0] for s in shown] == list(range(9))
    assert {(s[1], s[2]) for s in shown} == {(x, y) for x in (0.1, 0.5, 0.9) for y in (0.1, 0.5, 0.9)}
    calibration = session.fit_and_save(tmp_path / "calib.json")
    assert calibration.targets == 9 and calibration.residual_rms < 0.01
    loaded = load_calibration(tmp_path / "calib.json")
    point = loaded.apply(np.array([0.3 * (0.9 - 0.5) + 0.02 * 0.1, -0.2 * (0.1 - 0.5)]))
    np.testing.assert_allclose(point, [0.9, 0.1], atol=0.01)
