"""Recording the viewer's gaze and camera to files ``replay`` accepts.

One row per rendered frame: the gaze goes to a simple CSV trace (``t,x,y,confidence``,
t in seconds from the recording's start; ``warp-hybrid replay SCENE --gaze
trace:FILE``), the camera to ``FILE.camera.json`` beside it (schema
``warp-hybrid-viewer-camera``, version 1: the camera prim, the scene time the
recording started at, the fps, and per frame ``t``, the prim and ``cam_to_world``
row-major, which differs from the prim's own pose while the user orbits).  The
summary names the ``replay`` command that plays the recording back.
"""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

import numpy as np

from gaze.atomic import write_atomic
from gaze.source import GazeSample
from gaze.trace.simple_csv import write_simple

from ..scene.model import Camera

CAMERA_SCHEMA = "warp-hybrid-viewer-camera"
CAMERA_VERSION = 1


def camera_path_for(trace: Path) -> Path:
    """The camera file beside a trace: ``NAME.camera.json``."""
    return trace.with_suffix(".camera.json")


class Recorder:
    """Collects one row per frame between ``start`` and ``stop``."""

    def __init__(self, folder: Path, scene: str) -> None:
        """Recordings go to ``folder`` (created on the first one); ``scene`` names the scene file."""
        self.folder = Path(folder)
        self.scene = scene
        self._rows: list[tuple[float, GazeSample, str, np.ndarray]] | None = None
        self._t0 = 0.0
        self._scene_t0 = 0.0

    @property
    def recording(self) -> bool:
        """A recording is in progress."""
        return self._rows is not None

    def start(self, now: float, scene_t: float) -> None:
        """Start a recording at wall-clock ``now``, scene time ``scene_t`` (restarts one in progress)."""
        self._rows, self._t0, self._scene_t0 = [], now, scene_t

    def add(self, now: float, gaze: GazeSample, camera: Camera) -> None:
        """Record one frame's gaze and camera (ignored when not recording)."""
        if self._rows is not None:
            self._rows.append((now - self._t0, gaze, camera.name, np.array(camera.cam_to_world, dtype=float)))

    def stop(self, fps: float, camera_prim: str | None) -> dict[str, object]:
        """Write the trace and the camera file; returns what was written (``ValueError``
        when nothing was recorded)."""
        rows, self._rows = self._rows, None
        if not rows or not any(g.valid for _, g, _, _ in rows):
            raise ValueError("nothing to save: no frame with a valid gaze point was recorded")
        self.folder.mkdir(parents=True, exist_ok=True)
        stem = time.strftime("gaze-%Y%m%d-%H%M%S")
        trace = self.folder / f"{stem}.csv"
        for n in range(2, 1000):
            if not trace.exists():
                break
            trace = self.folder / f"{stem}-{n}.csv"
        t = np.array([r[0] for r in rows])
        write_simple(
            trace,
            t,
            np.array([g.x for _, g, _, _ in rows]),
            np.array([g.y for _, g, _, _ in rows]),
            np.array([g.confidence for _, g, _, _ in rows]),
            np.array([g.valid for _, g, _, _ in rows]),
        )
        camera_file = camera_path_for(trace)
        document = {
            "schema": CAMERA_SCHEMA,
            "version": CAMERA_VERSION,
            "scene": self.scene,
            "camera": camera_prim,
            "start": self._scene_t0,
            "fps": fps,
            "frames": [{"t": r[0], "camera": r[2], "cam_to_world": r[3].ravel().tolist()} for r in rows],
        }
        write_atomic(camera_file, json.dumps(document) + "\n")
        command = ["warp-hybrid", "replay", self.scene, "--gaze", f"trace:{trace}", "--fps", f"{fps:g}"]
        command += ["--start", f"{self._scene_t0:g}", "--duration", f"{max(float(t[-1]), 1.0 / fps):g}"]
        if camera_prim:
            command += ["--camera", camera_prim]
        return {
            "trace": str(trace),
            "camera_file": str(camera_file),
            "frames": len(rows),
            "replay": shlex.join(command + ["--out", "replay.mp4"]),
        }
