"""The viewer's server through aiohttp's test client: pages, static files, the WebSocket,
pointer gaze, validation, controls, recording."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import pytest_asyncio
from conftest import FPS, H, LiveViewer, W
from wsutil import frame_with_state, message, until

from gaze.factory import open_source
from warp_hybrid.viewer.protocol import schema_document
from warp_hybrid.viewer.recorder import CAMERA_SCHEMA
from warp_hybrid.viewer.server import STATIC_DIR, create_app

pytestmark = pytest.mark.asyncio


@pytest_asyncio.fixture
async def client(live: LiveViewer, aiohttp_client):  # type: ignore[no-untyped-def]
    """A test client of an app on the module's running viewer."""
    return await aiohttp_client(create_app(live.viewer, manage_thread=False))


async def test_the_page_and_its_files_load_with_a_strict_content_policy(client) -> None:  # type: ignore[no-untyped-def]
    page = await client.get("/")
    assert page.status == 200 and page.content_type == "text/html"
    text = await page.text()
    assert '<script src="/static/viewer.js">' in text and "http" not in text.replace('"/static/', "")
    assert "default-src 'none'" in page.headers["Content-Security-Policy"]
    for name in ("viewer.js", "viewer.css", "calibrate.js"):
        response = await client.get(f"/static/{name}")
        assert response.status == 200
        assert await response.read() == (STATIC_DIR / name).read_bytes()
    assert (await client.get("/calibrate")).status == 200
    assert await (await client.get("/protocol.json")).json() == schema_document()


@pytest.mark.parametrize(
    "path",
    [
        "/static/../server.py",
        "/static/%2e%2e/server.py",
        "/static/..%2fserver.py",
        "/static/%2e%2e%2f%2e%2e%2fpyproject.toml",
        "/static/..%5cserver.py",
        "/static/server.py",
        "/static/",
        "/static/.hidden",
        "/../../pyproject.toml",
    ],
)
async def test_a_path_outside_the_static_folder_gets_404(client, path: str) -> None:  # type: ignore[no-untyped-def]
    response = await client.get(path)
    assert response.status == 404
    assert b"import" not in await response.read()


async def test_hello_then_frames_and_the_pointer_moves_the_focus_window(client) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as ws:
        hello = await until(ws, "json", lambda m: m["type"] == "hello")
        assert (
            hello["v"] == 1
            and hello["animated"]
            and hello["cameras"] == ["/World/Cameras/Main", "/World/Cameras/AnimCam"]
        )
        header, jpeg = await until(ws, "frame")
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape == (H, W, 3) and (header["width"], header["height"]) == (W, H)
        for x, y, seq in ((0.85, 0.2, 1), (0.15, 0.8, 2)):
            await ws.send_str(message("pointer", x=x, y=y, seq=seq, sent_ms=1000.0 + seq))
            header, _ = await until(ws, "frame", lambda f: (f[0]["pointer"] or {}).get("seq") == seq)
            assert header["pointer"]["client"] == hello["client"] and header["pointer"]["sent_ms"] == 1000.0 + seq
            assert header["pointer"]["server_ms"] >= 0.0
            assert header["gaze"] == {"x": pytest.approx(x), "y": pytest.approx(y), "valid": True}
            cx, cy = header["window"]["centre"]
            assert (cx > W / 2) == (x > 0.5) and (cy > H / 2) == (y > 0.5)
        stats = header["stats"]
        assert stats["budget_ms"] == pytest.approx(1000.0 / FPS) and stats["frame_ms"] > 0.0
        assert 0.0 < stats["traced_fraction"] <= stats["window_fraction"] + 0.01  # whole pixels
        assert {"raster", "trace_shadow", "tonemap"} <= set(stats["stages_ms"])


BAD_MESSAGES = [
    ("{not json", "not JSON"),
    ("[1, 2]", "JSON object"),
    (json.dumps({"type": "pointer", "x": 0.5, "y": 0.5, "seq": 1, "sent_ms": 0}), "version"),
    (json.dumps({"v": 2, "type": "pointer", "x": 0.5, "y": 0.5, "seq": 1, "sent_ms": 0}), "version"),
    (message("teleport", x=1), "unknown message type"),
    (message("pointer", x=0.5, y=0.5, seq=1, sent_ms=0, z=3), "unknown field"),
    (message("pointer", x=0.5, seq=1, sent_ms=0), "missing field 'y'"),
    (message("pointer", x=1.5, y=0.5, seq=1, sent_ms=0), "pointer.x must lie in [0, 1]"),
    ('{"v": 1, "type": "pointer", "x": NaN, "y": 0.5, "seq": 1, "sent_ms": 0}', "NaN"),
    ('{"v": 1, "type": "pointer", "x": 0.5, "y": Infinity, "seq": 1, "sent_ms": 0}', "Infinity"),
    ('{"v": 1, "type": "pointer", "x": 0.5, "y": 1e999, "seq": 1, "sent_ms": 0}', "finite"),
    (message("pointer", x="0.5", y=0.5, seq=1, sent_ms=0), "must be a number"),
    (message("pointer", x=True, y=0.5, seq=1, sent_ms=0), "must be a number"),
    (message("pointer", x=0.5, y=0.5, seq=1.5, sent_ms=0), "whole number"),
    (message("control", mode="wireframe"), "must be one of"),
    (message("control", fps=0), "control.fps must lie in"),
    (message("control"), "at least one"),
    (message("camera", name="/World/Nope"), "unknown camera"),
    (message("seek", t=1e6), "seek: t must lie in"),
    (message("play", playing=1), "true or false"),
    (message("calibrate", action="start"), "calibration needs --gaze webcam"),
    (message("record", action="stop"), "not recording"),
]


async def test_bad_messages_are_refused_and_the_connection_stays_up(client, caplog) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")
        for text, why in BAD_MESSAGES:
            await ws.send_str(text)
            error = await until(ws, "json", lambda m: m["type"] == "error")
            assert why in error["message"], (text, error["message"])
        await ws.send_bytes(b"\x00\x01")
        assert "binary" in (await until(ws, "json", lambda m: m["type"] == "error"))["message"]
        await ws.send_str(message("pointer", x=0.3, y=0.4, seq=77, sent_ms=5.0))
        header, _ = await until(ws, "frame", lambda f: (f[0]["pointer"] or {}).get("seq") == 77)
        assert header["gaze"]["x"] == pytest.approx(0.3)
    assert sum("refused" in r.getMessage() for r in caplog.records) >= len(BAD_MESSAGES) - 1


async def test_an_oversized_message_closes_only_that_connection(client) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as other, client.ws_connect("/ws") as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")
        await ws.send_str(message("camera", name="x" * 10000))
        msg = await ws.receive(timeout=30)
        while msg.type.name in ("TEXT", "BINARY"):
            msg = await ws.receive(timeout=30)
        assert msg.type.name in ("CLOSE", "CLOSED", "CLOSING")
        await until(other, "frame")  # the other page still gets frames


async def test_controls_change_the_budget_mode_shape_camera_and_time(client) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")
        await ws.send_str(message("control", fps=10))
        header = await frame_with_state(ws, budget_ms=100.0)
        assert header["stats"]["budget_ms"] == pytest.approx(100.0)
        await ws.send_str(message("control", budget_ms=1000.0 / FPS, shape="rect"))
        header = await frame_with_state(ws, shape="rect")
        assert header["window"]["shape"] == "rect" and header["state"]["budget_ms"] == pytest.approx(1000 / FPS)
        await ws.send_str(message("control", mode="raster"))
        header = await frame_with_state(ws, mode="raster")
        assert header["window"] is None and header["stats"]["traced_fraction"] == 0.0
        await ws.send_str(message("control", mode="hybrid", shape="circle"))
        await frame_with_state(ws, mode="hybrid", shape="circle")
        await ws.send_str(message("camera", name="/World/Cameras/AnimCam"))
        await frame_with_state(ws, camera="/World/Cameras/AnimCam")
        await ws.send_str(message("play", playing=False))
        await ws.send_str(message("seek", t=0.5))
        header = await frame_with_state(ws, playing=False, t=0.5)
        assert header["t"] == pytest.approx(0.5)
        await ws.send_str(message("play", playing=True))
        header = await frame_with_state(ws, playing=True)
        await ws.send_str(message("camera", name="/World/Cameras/Main"))
        await frame_with_state(ws, camera="/World/Cameras/Main")


async def test_orbit_pan_zoom_change_the_image_and_reset_restores_it(client) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")
        await ws.send_str(message("play", playing=False))
        await ws.send_str(message("seek", t=0.0))
        await frame_with_state(ws, playing=False, t=0.0, navigating=False)
        _, before = await until(ws, "frame")
        for kind, dx, dy in (("orbit", 0.2, 0.05), ("pan", 0.1, 0.0), ("zoom", 0.0, -0.2)):
            await ws.send_str(message("navigate", kind=kind, dx=dx, dy=dy))
        await frame_with_state(ws, navigating=True)
        _, moved = await until(ws, "frame")
        await ws.send_str(message("reset_view"))
        await frame_with_state(ws, navigating=False)
        _, back = await until(ws, "frame")
        decode = lambda b: cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_GRAYSCALE).astype(float)  # noqa: E731
        assert np.abs(decode(moved) - decode(before)).mean() > 5.0
        assert np.abs(decode(back) - decode(before)).mean() < 3.0
        await ws.send_str(message("play", playing=True))
        await frame_with_state(ws, playing=True)


async def test_recording_writes_a_trace_replay_reads_and_the_camera(client, live: LiveViewer) -> None:  # type: ignore[no-untyped-def]
    async with client.ws_connect("/ws") as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")
        await ws.send_str(message("pointer", x=0.25, y=0.75, seq=1, sent_ms=0.0))
        await ws.send_str(message("record", action="start"))
        await until(ws, "json", lambda m: m.get("name") == "recording")
        await frame_with_state(ws, recording=True)
        for _ in range(5):
            await until(ws, "frame")
        await ws.send_str(message("record", action="stop"))
        done = await until(ws, "json", lambda m: m.get("name") == "recorded")
    trace = Path(done["trace"])
    assert trace.parent == live.record_dir and done["frames"] >= 5
    assert done["replay"].startswith("warp-hybrid replay ") and f"trace:{trace}" in done["replay"]
    with open_source(f"trace:{trace}") as source:
        sample = source.sample(0.0)
    assert (sample.x, sample.y, sample.valid) == (pytest.approx(0.25), pytest.approx(0.75), True)
    camera = json.loads(Path(done["camera_file"]).read_text())
    assert camera["schema"] == CAMERA_SCHEMA and len(camera["frames"]) == done["frames"]
    assert len(camera["frames"][0]["cam_to_world"]) == 16
