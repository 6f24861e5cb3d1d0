"""Per-frame error of a replay against full ray-traced references of the same frames.

``FrameErrors.keep`` (the replay's ``on_frame`` hook) stores each finished frame's
sRGB image and linear radiance in a temporary folder, with what the error needs: its
time, gaze, planned window and exposure.  ``FrameErrors.measure`` then, after the timed
loop (so the references never share the CPU with a timed frame), renders every kept
frame's reference (``--mode full`` at ``spp`` samples per pixel, the same scene time,
camera, size and tracing settings), exposes and tone maps it at that frame's own exposure
(a test frame and its reference never mix exposures; an automatic exposure is metered
on the test frame) and measures ``metrics.evaluate``: FLIP mean, foveated FLIP around
the frame's gaze, FLIP inside and outside the frame's window (where it was placed: with
``--saccade`` at the predicted landing point), PSNR.

``errors.csv`` (``ERROR_COLUMNS``): ``frame, t, gaze_x, gaze_y, window_fraction,
traced_fraction, exposure_ev, flip_mean, flip_foveated, flip_inside, flip_outside,
psnr``, one row per frame in frame order, written atomically once all are measured.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import statistics
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import warp as wp

from ..focus import FocusWindow
from ..metrics import ErrorReport, ViewingSetup, evaluate, layout_mask
from ..output import atomic_write_bytes
from ..post.postprocess import PostProcess
from ..renderer import Renderer, RenderSettings
from ..timing import StageTimer
from .loop import AdaptiveLoop, LoopFrame

#: The columns of ``errors.csv``, in order.
ERROR_COLUMNS = (
    "frame",
    "t",
    "gaze_x",
    "gaze_y",
    "window_fraction",
    "traced_fraction",
    "exposure_ev",
    "flip_mean",
    "flip_foveated",
    "flip_inside",
    "flip_outside",
    "psnr",
)


@dataclass(frozen=True)
class KeptFrame:
    """What the error of one replayed frame needs (its images are in the folder)."""

    index: int
    t: float
    gaze: tuple[float, float]
    window_centre: tuple[float, float]  # where the window was placed (``--saccade``: not the gaze)
    window_fraction: float
    traced_fraction: float
    exposure_ev: float


class FrameErrors:
    """Keeps a replay's frames and measures each against its reference (module docstring)."""

    def __init__(self, loop: AdaptiveLoop, spp: int = 16, viewing: ViewingSetup | None = None) -> None:
        """Measure ``loop``'s frames against references of ``spp`` samples per pixel."""
        self.loop = loop
        self.spp = spp
        self.viewing = viewing or ViewingSetup()
        self.kept: list[KeptFrame] = []
        self._folder = tempfile.TemporaryDirectory(prefix="warp-hybrid-errors-")
        RenderSettings(mode="full", spp=spp).validate()

    def close(self) -> None:
        """Delete the kept images."""
        self._folder.cleanup()

    def __enter__(self) -> FrameErrors:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _path(self, index: int) -> Path:
        return Path(self._folder.name) / f"frame_{index:06d}.npz"

    def keep(self, frame: LoopFrame) -> None:
        """Store ``frame``'s images and its metadata (call before the next frame renders)."""
        np.savez(self._path(frame.index), srgb=frame.frame.image, linear=frame.frame.color)
        gaze = (frame.gaze.x, frame.gaze.y)
        placed = (frame.frame.stats.get("window") or {}).get("gaze")
        self.kept.append(
            KeptFrame(
                index=frame.index,
                t=frame.t,
                gaze=gaze,
                window_centre=tuple(placed) if placed is not None else gaze,
                window_fraction=frame.window_fraction,
                traced_fraction=frame.traced_fraction,
                exposure_ev=float(frame.frame.stats["exposure_ev"]),
            )
        )

    def _reference_settings(self) -> RenderSettings:
        """The replay's settings as full ray tracing at ``spp`` samples per pixel (a fixed
        exposure: each reference is exposed at its frame's own EV afterwards)."""
        rs = self.loop.renderer.settings
        return dataclasses.replace(rs, mode="full", spp=self.spp, fovea_spp=1, exposure_ev=0.0)

    def measure(self, on_row: Callable[[], None] | None = None) -> list[dict[str, Any]]:
        """Every kept frame's error row (``ERROR_COLUMNS``), in frame order;
        ``on_row`` is called after each."""
        if not self.kept:
            return []
        loop = self.loop
        rs = loop.renderer.settings
        source = loop.source
        scene = source.scene_at(loop.time_code(self.kept[0].t))
        rows = []
        with Renderer(scene, self._reference_settings()) as reference:
            post = PostProcess(reference.launcher)
            for kept in self.kept:
                code = loop.time_code(kept.t)
                if code != scene.time:
                    scene = source.scene_at(code)
                    reference.update_scene(scene)
                linear = reference.render(loop.camera_in(scene)).color
                device_linear = wp.array(linear, dtype=wp.vec3, device=reference.device)
                srgb = post.process(device_linear, kept.exposure_ev, rs.tonemap, rs.antialias, StageTimer()).numpy()
                images = np.load(self._path(kept.index))
                window = None
                if rs.mode == "hybrid":
                    window_at = FocusWindow(kept.window_centre, kept.window_fraction, rs.window_shape)
                    layout = window_at.layout(rs.width, rs.height)
                    window = layout_mask(layout)
                error = evaluate(srgb, images["srgb"], linear, images["linear"], kept.gaze, window, self.viewing)
                rows.append(_row(kept, error))
                if on_row is not None:
                    on_row()
        return rows


def _row(kept: KeptFrame, error: ErrorReport) -> dict[str, Any]:
    """One ``errors.csv`` row."""
    return {
        "frame": kept.index,
        "t": f"{kept.t:.6f}",
        "gaze_x": f"{kept.gaze[0]:.6f}",
        "gaze_y": f"{kept.gaze[1]:.6f}",
        "window_fraction": f"{kept.window_fraction:.6f}",
        "traced_fraction": f"{kept.traced_fraction:.6f}",
        "exposure_ev": f"{kept.exposure_ev:.6f}",
        "flip_mean": f"{error.flip_mean:.6f}",
        "flip_foveated": f"{error.flip_foveated:.6f}",
        "flip_inside": f"{error.flip_inside:.6f}",
        "flip_outside": f"{error.flip_outside:.6f}",
        "psnr": f"{error.psnr:.3f}",
    }


def write_errors(path: str | Path, rows: list[dict[str, Any]]) -> None:
    """Write ``errors.csv`` atomically (a whole file or none)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=ERROR_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_bytes(path, out.getvalue().encode())


def error_summary(rows: list[dict[str, Any]]) -> dict[str, float]:
    """The medians over the frames of the foveated FLIP, FLIP inside and outside the
    window, and PSNR (NaN-free values only; NaN when none)."""
    summary = {}
    for name in ("flip_foveated", "flip_inside", "flip_outside", "flip_mean", "psnr"):
        values = [float(r[name]) for r in rows if np.isfinite(float(r[name]))]
        summary[f"median_{name}"] = statistics.median(values) if values else float("nan")
    return summary
