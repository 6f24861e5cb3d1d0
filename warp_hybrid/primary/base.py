"""Primary visibility as one pass with two ways to find the nearest surface (Falcor's
``GBufferBase`` -> ``GBufferRaster`` / ``GBufferRT``).

``PrimaryVisibility.render`` checks the sizes, lets the subclass write each pixel's hit
record (``find_hits``: rasterized in ``Rasterizer``, ray cast in ``RayCaster``; the
background's record where no surface is hit), or leave it for the surface pass to resolve
from the coverage pass's keys as it reads them (``hits_for_surface``: ``Rasterizer``, so
the hit record is not written by one pass and read back by the next), then runs the
surface pass both share
(stage "surface": the material at each hit record, textures filtered over the pixel's
footprint, into every other channel; the background's values elsewhere).  Every pixel
is written, so there is no clear first (stage "clear" no longer runs; its stats column
stays, always 0).  The lighting, tracing and composition stages never know which path
ran.
"""

from __future__ import annotations

from abc import abstractmethod

import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer
from ..core.passes import FrameContext, RenderPass
from ..core.rows import RowSpan
from ..parallel import Launcher
from ..scene.device import DeviceScene
from ..timing import StageTimer
from . import kernels


class PrimaryVisibility(RenderPass):
    """Fills the frame's G-buffer (see the module docstring)."""

    overlapped = True

    def __init__(self, launcher: Launcher) -> None:
        """Use ``launcher`` for the device and the host threads."""
        self.launcher = launcher
        #: Whether the surface pass writes the ``geometric_normal`` channel, which only traced
        #: rays (their offsets) and the shadow maps' lookups read: a renderer whose frames do
        #: neither turns it off (``Renderer``), and the channel is left as it was (the
        #: G-buffer says so: ``GBuffer.geometric_normals``).
        self.geometric_normals = True
        launcher.ensure_loaded(kernels.surface_kernel)  # the primary kernels' one module
        # the surface kernel's key slices where the hit record is in the G-buffer: none
        self._no_keys = wp.empty((0, 0, 0), dtype=wp.uint64, device=launcher.device)

    def execute(self, frame: FrameContext) -> None:
        """Fill ``frame``'s G-buffer (its ``raster_rows``) from the scene set with ``set_scene``."""
        assert self.scene is not None, "set_scene first"
        self.render(self.scene, frame.camera, frame.gbuffer, frame.timer, frame.raster_rows)

    def render(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> None:
        """Fill ``gbuffer`` with ``scene`` seen by ``camera`` (every pixel of ``rows``, default
        every row, written; the other rows untouched)."""
        if (camera.width, camera.height) != (gbuffer.width, gbuffer.height):
            raise ValueError(
                f"camera is for {camera.width}x{camera.height} but the G-buffer is {gbuffer.width}x{gbuffer.height}"
            )
        keys = self.hits_for_surface(scene, camera, gbuffer, timer, rows)
        with timer.stage("surface"):
            every_row = rows is None or (rows[0] <= 0 and rows[1] >= gbuffer.height)
            write_emission = gbuffer.surface_writes_emission(scene.features.emission, every_row)
            gbuffer.surface_draws_geometric_normals(self.geometric_normals, every_row)
            channels = (kernels.SURFACE_EMISSION if write_emission else 0) | (
                kernels.SURFACE_GEOMETRIC_NORMAL if self.geometric_normals else 0
            )
            self.launcher.launch_pixels(
                kernels.surface_kernel,
                gbuffer.height,
                gbuffer.width,
                [
                    scene.gpu,
                    camera,
                    self._no_keys if keys is None else keys,
                    gbuffer.rows(),
                    gbuffer.background_blocks,
                    channels,
                ],
                rows=rows,
            )

    def hits_for_surface(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> wp.array | None:
        """Where the surface pass that ``render`` runs next takes each pixel's hit record
        from: None where this wrote it into ``gbuffer`` (``find_hits``, here), or key
        slices whose smallest key names each pixel's triangle, which the surface pass
        resolves into the hit record as it reads them (``Rasterizer``)."""
        self.find_hits(scene, camera, gbuffer, timer, rows)
        return None

    @abstractmethod
    def find_hits(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> None:
        """Write the hit record (triangle, depth, barycentrics) of every pixel of ``rows``
        (default every row): the background's (``gbuffer.BACKGROUND``) where it sees no
        surface."""
