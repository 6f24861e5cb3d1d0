"""Ray-cast primary visibility: the reference the raster path is tested against.

One ``wp.mesh_query_ray`` per pixel centre, from the near plane to the far plane,
stepping past hits in alpha cut-out holes; fills the same ``GBuffer`` as
``Rasterizer`` (stage "raycast", then the shared attribute pass, stage "surface").
"""

from __future__ import annotations

from ..parallel import Launcher
from ..scene.device import CameraGPU, DeviceScene
from ..timing import StageTimer
from . import kernels
from .gbuffer import GBuffer
from .rasterizer import check_size, evaluate_surfaces


class RayCaster:
    """Fills a ``GBuffer`` by casting primary rays through the BVH (stage "raycast")."""

    def __init__(self, launcher: Launcher) -> None:
        """Use ``launcher`` for the device and the host threads."""
        self.launcher = launcher

    def render(self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer) -> None:
        """Cast one ray per pixel centre of ``camera`` into ``scene`` (every pixel written)."""
        check_size(camera, gbuffer)
        with timer.stage("raycast"):
            self.launcher.launch_rows(
                kernels.raycast_kernel,
                gbuffer.height,
                gbuffer.width,
                [scene.gpu, camera, kernels.gbuffer_rows(gbuffer)],
            )
        evaluate_surfaces(self.launcher, scene, camera, gbuffer, timer)
