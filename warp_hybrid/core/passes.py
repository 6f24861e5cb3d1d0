"""The render-pass interface and the explicit state of one frame (Falcor's render passes).

Every stage is a ``RenderPass`` with the same small lifecycle: ``set_scene`` (the
device scene to draw, again after every scene update), ``resize`` (the frame size),
``execute`` (run on one frame's ``FrameContext``).  A pass reads what earlier passes
left in the context and writes its own outputs there, so a new pass (shadow maps, a
mid-resolution ring) is a new class placed in the renderer's pass list, and no pass
holds per-frame state of its own.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import warp as wp

from ..timing import StageTimer
from .camera import CameraGPU
from .gbuffer import GBuffer
from .rows import RowSpan

if TYPE_CHECKING:
    from ..focus import FocusRegion, FocusWindow
    from ..scene.device import DeviceScene
    from ..scene.model import Camera
    from ..trace import RayTally


class FrameBuffers:
    """The per-pixel buffers a frame is drawn into, reused across frames: the G-buffer,
    the raster and traced radiance layers, the composed ``color`` (linear radiance
    before exposure), ``metered`` (the layer automatic exposure is metered on: ``color``
    unless the renderer says otherwise) and the per-light ``visibility`` AOV
    (transmittance luminance, NaN where not traced).  ``color_rows`` and ``color_cols``
    say what ``color`` holds between frames: the only rows and columns where it may
    differ from ``raster_color`` (None: any; set by the passes that write ``color``)."""

    def __init__(self, width: int, height: int, lights: int, device: wp.context.Device) -> None:
        """Allocate every buffer for ``width`` x ``height`` and ``lights`` lights."""
        self.width = width
        self.height = height
        self.device = device
        shape = (height, width)
        self.gbuffer = GBuffer(width, height, device)
        self.raster_color = wp.zeros(shape, dtype=wp.vec3, device=device)
        self.traced_color = wp.zeros(shape, dtype=wp.vec3, device=device)
        self.color = wp.zeros(shape, dtype=wp.vec3, device=device)
        self.metered = self.color
        self.color_rows: RowSpan | None = None
        self.color_cols: RowSpan | None = None
        self.visibility = wp.full((height, width, lights), value=float("nan"), dtype=wp.float32, device=device)

    def fits(self, width: int, height: int, lights: int) -> bool:
        """Whether these buffers serve a frame of this size and light count."""
        return (self.width, self.height, self.visibility.shape[2]) == (width, height, lights)


@dataclass(frozen=True)
class MeteredRows:
    """A layer's log-luminance sums per row, as the post stage's automatic exposure meters
    them (``post.kernels``: float64 sum and count of each row's hit pixels), left by the
    pass that wrote the layer and metered it as it went (``DeferredLighting``), so the
    post stage need not read it again."""

    layer: wp.array
    row_sum: wp.array
    row_count: wp.array


@dataclass
class FrameContext:
    """Everything one frame's passes share, explicitly: the camera, the stage timer,
    the buffers, this frame's focus window, and what passes produce for later ones
    (the focus region, the ray tally, the image).

    A supersampled frame runs its passes once per sample (sub-frame): ``camera``
    samples sub-frame ``sample_index``'s point in each pixel, and passes that keep
    per-frame totals (the ray tally) start them at sample 0 only.  ``view`` is the scene
    camera ``camera`` was made from, for passes that sample other points in each pixel.
    ``raster_cached``: the raster layer (and the G-buffer) are the previous frame's, kept
    for a still view (``RenderSettings.cache_raster``).  ``raster_rows``: the only rows of
    the raster layer (and the G-buffer) the raster-layer passes draw, the rest being the
    previous frame's (a still view where only a small part of the scene moved); None:
    every row.  ``changed_rows`` and
    ``changed_cols``: the only rows and columns of ``buffers.color`` that can differ from
    the previous frame's (None: any): none where the raster layer was kept, then widened
    by each pass that writes ``color``.  ``metered_rows``: a layer's log-luminance sums,
    metered by the pass that wrote it this frame (None once a later pass changes it)."""

    camera: CameraGPU
    timer: StageTimer
    buffers: FrameBuffers
    window: FocusWindow | None = None
    trace_deadline: float | None = None
    region: FocusRegion | None = None
    rays: RayTally | None = None
    image: Any = None
    stats: dict[str, Any] = field(default_factory=dict)
    sample_index: int = 0
    view: Camera | None = None
    raster_cached: bool = False
    raster_rows: RowSpan | None = None
    changed_rows: RowSpan | None = None
    changed_cols: RowSpan | None = None
    metered_rows: MeteredRows | None = None

    @property
    def gbuffer(self) -> GBuffer:
        """This frame's G-buffer."""
        return self.buffers.gbuffer


class RenderPass(ABC):
    """One stage of a frame (see the module docstring)."""

    scene: DeviceScene | None = None
    #: Whether the pass reads and writes a frame's data only through its launcher's passes
    #: (or after ``Launcher.join``), so its last pass may still run while the Python after
    #: it does (``Launcher.overlapping``); the renderer runs every other pass with the
    #: launcher ``paused``.
    overlapped: bool = False

    def set_scene(self, scene: DeviceScene) -> None:
        """Draw ``scene`` from now on (called again after every scene update)."""
        self.scene = scene

    def resize(self, width: int, height: int) -> None:
        """Frames are ``width`` x ``height`` from now on (passes with sized state override)."""

    @abstractmethod
    def execute(self, frame: FrameContext) -> None:
        """Run this pass on ``frame``."""
