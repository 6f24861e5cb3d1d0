"""What a page's validated message does: the viewer's controls, and the ``hello`` a page gets.

``Viewer`` ties the render thread, the frame hub and the gaze feed together.
``handle`` turns a ``protocol.ClientMessage`` into a render-thread control; the checks
that need the scene (a camera it has, a time within its range, a pointer when the
cursor is the gaze) raise ``ProtocolError`` too.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..focus import SHAPES
from ..renderer import MODES
from .gaze_feed import PointerGaze, webcam_spec
from .hub import FrameHub
from .protocol import ClientMessage, ProtocolError, schema_document, server_message
from .render_thread import RenderThread


class Viewer:
    """One scene shown to any number of pages."""

    def __init__(self, thread: RenderThread, hub: FrameHub) -> None:
        self.thread = thread
        self.hub = hub

    @property
    def scene_name(self) -> str:
        """The scene file's name."""
        return Path(str(self.thread.source.path)).name

    def hello(self, client: int) -> dict[str, Any]:
        """The first message a page gets: who it is, the scene, the choices, the state."""
        return server_message(
            "hello",
            client=client,
            scene=self.scene_name,
            cameras=self.thread.cameras,
            modes=list(MODES),
            shapes=list(SHAPES),
            animated=self.thread.timeline.animated,
            duration=self.thread.timeline.duration,
            state=self.thread.state,
            protocol=schema_document(),
        )

    def handle(self, client: int, message: ClientMessage) -> None:
        """Apply a validated message from page ``client``; ``ProtocolError`` when the
        scene or the gaze mode refuses it."""
        f = message.fields
        thread = self.thread
        if message.type == "pointer":
            feed = thread.feed
            if not isinstance(feed, PointerGaze):
                raise ProtocolError(f"pointer: the gaze is {feed.kind}, not the cursor")
            feed.pointer(client, f["x"], f["y"], f["seq"], f["sent_ms"])
        elif message.type == "control":
            if "budget_ms" in f or "fps" in f:
                thread.set_budget(f["budget_ms"] if "budget_ms" in f else 1000.0 / f["fps"])
            changes = {"mode": f.get("mode"), "window_shape": f.get("shape")}
            changes = {k: v for k, v in changes.items() if v is not None}
            if changes:
                thread.set_render(**changes)
        elif message.type == "camera":
            if f["name"] not in thread.cameras:
                raise ProtocolError(f"camera: unknown camera {f['name']!r:.80}; the scene has {thread.cameras}")
            thread.select_camera(f["name"])
        elif message.type == "navigate":
            thread.navigate(f["kind"], f["dx"], f["dy"])
        elif message.type == "reset_view":
            thread.reset_view()
        elif message.type == "play":
            thread.play(f["playing"])
        elif message.type == "seek":
            if f["t"] > thread.timeline.duration:
                raise ProtocolError(f"seek: t must lie in [0, {thread.timeline.duration:g}], got {f['t']:g}")
            thread.seek(f["t"])
        elif message.type == "record":
            thread.record(f["action"] == "start", client)
        elif message.type == "calibrate":
            if webcam_spec(thread.settings.gaze) is None:
                raise ProtocolError(f"calibrate: the gaze is {thread.feed.kind}; calibration needs --gaze webcam:INDEX")
            thread.calibrate(f["action"] == "start", client)
