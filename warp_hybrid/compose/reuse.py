"""Temporal reuse of the traced layer (``--reuse``, hybrid mode; stage "reuse").

A pixel that just left the focus window still has, a frame ago, a traced value.  This
pass keeps the last frames' traced estimate per pixel (the history) and, after the
compose, shows it in the share of each pixel the current window does not trace:

    out = composed + (1 - w) u (H - raster)

with ``w`` the pixel's compose weight this frame, ``H`` the history reprojected to the
pixel and ``u`` its reuse weight.  Reprojection follows the G-buffer: the pixel's point
(``position``, the scene's local frame) is projected into the previous frame's camera;
the nearest previous pixel is reused only when it saw the same surface there: its view
depth within ``DEPTH_TOLERANCE`` (relative) of the point's depth in the previous camera
and its normal within ``NORMAL_TOLERANCE`` (cosine) of the current one.  Otherwise
(disocclusion, a surface that moved, off screen, background) nothing is reused.

Fading: the history stores each pixel's age, the frames since it was last traced (0 in
a frame where its compose weight is at least one half).  A history of age ``a`` is
reused with ``u = clamp(1 - a / FADE_FRAMES, 0, 1)``: whole in the first frame after the
window left (the trace of one frame ago), then fading to the raster layer over
``FADE_FRAMES`` frames, so nothing stale stays.  Tracing costs nothing here: the pass is
one projection and one fetch per pixel.  Automatic exposure is metered on the raster
layer before this pass, so reuse never changes the exposure.  A new size, scene or
device scene (``set_scene``) starts the history again; a frame rendered without a window
(raster or full mode) never reaches this pass.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBufferArrays
from ..core.passes import FrameContext, RenderPass
from ..parallel import Launcher
from ..scene.device import DeviceScene

#: Frames over which a reused value fades to the raster layer.
FADE_FRAMES = 4
#: A previous pixel shows the same surface when its view depth is within this share of
#: the point's depth in the previous camera ...
DEPTH_TOLERANCE = 0.01
#: ... and its normal within this cosine of the current one.
NORMAL_TOLERANCE = 0.9
#: The age of a pixel with nothing to reuse.
NO_HISTORY = 1.0e9


@wp.struct
class HistoryGPU:
    """The previous frame as the reuse kernel reads it: camera, traced estimate, its age,
    view depth and normal per pixel."""

    cam: CameraGPU
    color: wp.array2d(dtype=wp.vec3)
    age: wp.array2d(dtype=wp.float32)
    depth: wp.array2d(dtype=wp.float32)
    normal: wp.array2d(dtype=wp.vec3)


@wp.func
def project_to_pixel(cam: CameraGPU, p: wp.vec3) -> wp.vec3:
    """Image point (px, py) in pixels and view depth of ``p`` seen by ``cam`` (the
    inverse of ``camera.camera_ray``); depth <= 0 behind the camera."""
    d = p - cam.origin
    z = wp.dot(d, cam.forward)
    if z <= 0.0:
        return wp.vec3(0.0, 0.0, z)
    ndc_x = wp.dot(d, cam.right) / (z * cam.tan_x)
    ndc_y = wp.dot(d, cam.up) / (z * cam.tan_y)
    return wp.vec3((ndc_x + 1.0) * 0.5 * float(cam.width), (1.0 - ndc_y) * 0.5 * float(cam.height), z)


@wp.kernel(enable_backward=False)
def reuse_pixels(
    gb: GBufferArrays,
    weight: wp.array2d(dtype=wp.float32),
    traced: wp.array2d(dtype=wp.vec3),
    raster: wp.array2d(dtype=wp.vec3),
    prev: HistoryGPU,
    has_prev: int,
    color: wp.array2d(dtype=wp.vec3),
    next_color: wp.array2d(dtype=wp.vec3),
    next_age: wp.array2d(dtype=wp.float32),
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: blend the reprojected history into ``color`` (module docstring) and
    write this frame's history (``next_*``; depth and normal are copied by the host)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
        w = weight[y, x]
        age = float(NO_HISTORY)
        reused = wp.vec3(0.0, 0.0, 0.0)
        if has_prev != 0 and gb.triangle_id[y, x] >= 0:
            p = gb.position[y, x]
            q = project_to_pixel(prev.cam, p)
            qx = int(wp.floor(q[0]))
            qy = int(wp.floor(q[1]))
            if q[2] > 0.0 and qx >= 0 and qy >= 0 and qx < prev.cam.width and qy < prev.cam.height:
                same = wp.abs(prev.depth[qy, qx] - q[2]) <= DEPTH_TOLERANCE * q[2]
                if same and wp.dot(prev.normal[qy, qx], gb.normal[y, x]) >= NORMAL_TOLERANCE:
                    age = prev.age[qy, qx]
                    reused = prev.color[qy, qx]
        u = wp.clamp(1.0 - age / float(FADE_FRAMES), 0.0, 1.0)
        if u > 0.0 and w < 1.0:
            color[y, x] = color[y, x] + (reused - raster[y, x]) * ((1.0 - w) * u)
        if w >= 0.5:
            next_color[y, x] = traced[y, x]
            next_age[y, x] = 0.0
        elif u > 0.0:
            next_color[y, x] = reused
            next_age[y, x] = age + 1.0
        else:
            next_color[y, x] = wp.vec3(0.0, 0.0, 0.0)
            next_age[y, x] = float(NO_HISTORY)


class _History:
    """One frame's history buffers (two of them swap every frame) and their kernel struct."""

    def __init__(self, width: int, height: int, device: wp.context.Device) -> None:
        shape = (height, width)
        self.color = wp.zeros(shape, dtype=wp.vec3, device=device)
        self.age = wp.full(shape, value=NO_HISTORY, dtype=wp.float32, device=device)
        self.depth = wp.zeros(shape, dtype=wp.float32, device=device)
        self.normal = wp.zeros(shape, dtype=wp.vec3, device=device)
        self.gpu = HistoryGPU()
        self.gpu.cam = CameraGPU()
        self.gpu.color, self.gpu.age, self.gpu.depth, self.gpu.normal = self.color, self.age, self.depth, self.normal


class TemporalReuse(RenderPass):
    """Shows the last frames' traced values where the window no longer traces (module
    docstring); after the compose, hybrid mode only."""

    def __init__(self, launcher: Launcher) -> None:
        """Run on ``launcher``'s device and threads."""
        self.launcher = launcher
        self._pair: list[_History] | None = None
        self._valid = False  # whether _pair[0] holds a previous frame

    def set_scene(self, scene: DeviceScene) -> None:
        """A new device scene (or the same one after an update) keeps the history: the
        depth and normal tests reject what moved.  Only a different device scene starts
        again."""
        if scene is not self.scene:
            self._valid = False
        super().set_scene(scene)

    def resize(self, width: int, height: int) -> None:
        """Frames of a new size start the history again."""
        self._pair = None
        self._valid = False

    def reset(self) -> None:
        """Forget the history (the next frame reuses nothing): a camera cut."""
        self._valid = False

    def execute(self, frame: FrameContext) -> None:
        """Blend the history into ``frame``'s colour and keep this frame's."""
        assert frame.region is not None, "the focus pass runs first"
        b = frame.buffers
        h, w = b.height, b.width
        if self._pair is None or self._pair[0].color.shape != (h, w):
            self._pair = [_History(w, h, self.launcher.device) for _ in range(2)]
            self._valid = False
        prev, nxt = self._pair
        with frame.timer.stage("reuse"):
            inputs = [
                b.gbuffer.kernel_arrays(),
                frame.region.weight,
                b.traced_color,
                b.raster_color,
                prev.gpu,
                int(self._valid),
                b.color,
                nxt.color,
                nxt.age,
            ]
            self.launcher.launch_pixels(reuse_pixels, h, w, inputs)
            b.color_rows = frame.changed_rows = None  # reused pixels may lie anywhere
            b.color_cols = frame.changed_cols = None
            wp.copy(nxt.depth, b.gbuffer.depth)
            wp.copy(nxt.normal, b.gbuffer.normal)
            nxt.gpu.cam = frame.camera
        self._pair = [nxt, prev]
        self._valid = True
