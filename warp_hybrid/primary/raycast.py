"""Ray-cast primary visibility: the reference the raster path is tested against.

One ``wp.mesh_query_ray`` per pixel centre, from the near plane to the far plane,
stepping past hits in alpha cut-out holes (stage "raycast"; ``kernels.raycast_kernel``).
"""

from __future__ import annotations

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer
from ..scene.device import DeviceScene
from ..timing import StageTimer
from . import kernels
from .base import PrimaryVisibility


class RayCaster(PrimaryVisibility):
    """Finds each pixel's nearest surface by casting its camera ray through the BVH."""

    def find_hits(self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer) -> None:
        """One ray per pixel centre of ``camera`` (stage "raycast")."""
        with timer.stage("raycast"):
            self.launcher.launch_pixels(
                kernels.raycast_kernel, gbuffer.height, gbuffer.width, [scene.gpu, camera, gbuffer.rows()]
            )
