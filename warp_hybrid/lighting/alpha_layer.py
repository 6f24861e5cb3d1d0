"""What shows behind alpha-blended surfaces in the raster layer: a second visibility layer
(stage "alpha_layer", raster and hybrid modes).

A pixel whose nearest surface is alpha-blended (``FLAG_BLENDED``, coverage alpha = its
opacity; ``Material.is_blended``) shows alpha of that surface, which the lighting pass
has already shaded as an opaque one, and 1 - alpha of what lies behind it.
``AlphaLayer`` finds what lies behind by rasterizing the scene once more with its
blended triangles hidden (``scene.device.subset.hide_materials``) into a second G-buffer,
with the same rasterizer and surface pass, shades it with the same deferred lighting
(shadowed by the same shadow maps and reflecting the same probe when they are on; the
dome where nothing is behind),
and blends ``alpha x front + (1 - alpha) x behind`` where the front surface is blended.
The traced window needs none of this: its rays pass blended surfaces themselves
(``trace/path.py``), and the raster layer under it is what the budget guard falls back on.

One layer: behind a blended surface the nearest surface that is not blended shows, so
of several blended surfaces in a row only the nearest is drawn (order-independent
transparency over any number of layers is not done).  The second layer is always
rasterized, whichever primary path the renderer uses.  A scene without blended
materials (``SceneFeatures.blending``) skips the pass: nothing compiles, runs or is
allocated.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer, GBufferArrays
from ..core.passes import FrameContext, RenderPass
from ..core.scene_gpu import FLAG_BLENDED, SceneGPU
from ..parallel import Launcher
from ..primary import Rasterizer
from ..scene.device import DeviceScene
from ..scene.device.subset import hide_materials
from ..timing import StageTimer
from .deferred import DeferredLighting
from .probes import ReflectionProbe
from .shadow_maps import ShadowMaps


@wp.kernel(enable_backward=False)
def blend_behind_pixels(
    scene: SceneGPU,
    front: GBufferArrays,
    behind: wp.array2d(dtype=wp.vec3),
    color: wp.array2d(dtype=wp.vec3),
    row0: int,
    row_step: int,
    cols: int,
):
    """``color = alpha x color + (1 - alpha) x behind`` where the front surface is blended."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
        mid = front.material_id[y, x]
        if mid >= 0:
            if (scene.materials[mid].flags & FLAG_BLENDED) != 0:
                a = wp.clamp(front.optics[y, x].opacity, 0.0, 1.0)
                color[y, x] = color[y, x] * a + behind[y, x] * (1.0 - a)


class AlphaLayer(RenderPass):
    """Blends what lies behind alpha-blended surfaces into the raster layer (module
    docstring); runs after the lighting pass, on ``shadow_maps`` when given."""

    overlapped = True

    def __init__(
        self, launcher: Launcher, shadow_maps: ShadowMaps | None = None, probe: ReflectionProbe | None = None
    ) -> None:
        """Draw on ``launcher``'s device and threads; shade with the frame's ``shadow_maps``
        and reflection ``probe`` where they are on, as the lighting pass does."""
        self.launcher = launcher
        self.shadow_maps = shadow_maps
        self.probe = probe
        self._rasterizer = Rasterizer(launcher)
        self._rasterizer.geometric_normals = shadow_maps is not None  # (no ray leaves the layer behind)
        self._lighting = DeferredLighting(launcher, shadow_maps, probe)
        self._behind: GBuffer | None = None
        self._behind_color: wp.array | None = None
        self._view: DeviceScene | None = None
        self._previous: DeviceScene | None = None  # the last view, whose indices a new one may reuse

    def set_scene(self, scene: DeviceScene) -> None:
        """Draw ``scene`` from now on (the view without its blended triangles is made
        again at the next frame that needs it)."""
        super().set_scene(scene)
        self._previous = self._view or self._previous
        self._view = None

    def execute(self, frame: FrameContext) -> None:
        """Blend the layer behind into ``frame``'s raster layer (nothing without blended
        materials)."""
        assert self.scene is not None, "set_scene first"
        if not self.scene.features.blending:
            return
        with frame.timer.stage("alpha_layer"):
            inner = StageTimer(clock=frame.timer.clock, sync=frame.timer.sync)
            self.blend(self.scene, frame.camera, frame.gbuffer, frame.buffers.raster_color, inner)
        frame.metered_rows = None  # (the layer changed since it was metered)

    def blend(self, scene: DeviceScene, camera: CameraGPU, front: GBuffer, color: wp.array, timer: StageTimer) -> None:
        """Draw and shade what lies behind ``front``'s blended pixels and blend it into
        ``color`` ((H, W) vec3, the shaded front layer); ``timer`` gets the second layer's
        own stages (clear, raster, resolve, surface, lighting)."""
        if self._view is None:
            self._view = hide_materials(scene, lambda m: m.is_blended, self._previous)
        h, w = front.height, front.width
        if self._behind is None or (self._behind.width, self._behind.height) != (w, h):
            self._behind = GBuffer(w, h, self.launcher.device)
            self._behind_color = wp.zeros((h, w), dtype=wp.vec3, device=self.launcher.device)
        self._rasterizer.render(self._view, camera, self._behind, timer)
        maps = self.shadow_maps.gpu if self.shadow_maps is not None else None
        probe = self.probe.gpu if self.probe is not None else None
        self._lighting.shade(self._view, camera, self._behind, self._behind_color, timer, maps, probe)
        self.launcher.launch_pixels(
            blend_behind_pixels, h, w, [scene.gpu, front.kernel_arrays(), self._behind_color, color]
        )
