"""Ray-cast primary visibility: the reference the raster path is tested against.

One closest-hit query per pixel centre, from the near plane to the far plane, stepping
past hits in alpha cut-out holes (stage "raycast"; ``kernels.raycast_kernel``).  The
query is the scene's 4-wide BVH copy (``DeviceScene.wide_bvh``: Warp's answers, the
stage 1.6-2.3x faster, ``scripts/bench_raster.py``) where ``wide_bvh`` resolves on
(``wide_bvh.use_wide_bvh``: the CPU's default), else ``wp.mesh_query_ray``.
"""

from __future__ import annotations

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer
from ..core.rows import RowSpan
from ..parallel import Launcher
from ..scene.device import DeviceScene
from ..scene.device.wide_bvh import use_wide_bvh
from ..timing import StageTimer
from . import kernels
from .base import PrimaryVisibility


class RayCaster(PrimaryVisibility):
    """Finds each pixel's nearest surface by casting its camera ray through the BVH."""

    def __init__(self, launcher: Launcher, wide_bvh: bool | None = None) -> None:
        """Use ``launcher``; ``wide_bvh`` as ``RenderSettings.wide_bvh`` (None: the
        4-wide copy on the CPU, Warp's query on CUDA)."""
        super().__init__(launcher)
        #: Whether the rays query the scene's 4-wide BVH copy.
        self.wide_bvh = use_wide_bvh(wide_bvh, launcher.device)

    def find_hits(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> None:
        """One ray per pixel centre of ``camera`` in ``rows`` (default every row; stage "raycast")."""
        with timer.stage("raycast"):
            self.launcher.launch_pixels(
                kernels.raycast_kernel,
                gbuffer.height,
                gbuffer.width,
                [scene.gpu, scene.query_bvh(self.wide_bvh).gpu, camera, gbuffer.rows()],
                rows=rows,
            )
