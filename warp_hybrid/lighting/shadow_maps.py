"""Shadow maps for the raster layer: every light's depth map, rendered by the project's
rasterizer and cached until the geometry or the lights move (stage "shadow_maps").

Per light kind (faces are square, ``size`` x ``size`` texels, one pinhole camera each):

* sphere, rect and disk lights (spot cones included): a cube map at the light's
  position, six faces of 90 degrees; for one-sided emitters (rect, disk, and any light
  whose cone is at most 90 degrees) only the faces that see the emitting half space are
  rendered (the others stay empty: nothing there is lit).  The near plane is the sphere
  light's radius (shadow rays stop at its surface) or ``NEAR_FRACTION`` of the far one.
* distant lights: one face, a perspective camera ``DISTANT_BACK`` times the scene's
  size R back along the light's direction (R the larger of the bounding box's half
  extents across and along the light), with the narrow field of view that just holds
  the box's projection across the light: a near-orthographic map (rays within
  1 / 255 rad of parallel, so a shadow moves by at most 0.4% of its caster's height;
  float32 depths at D = 256 R round to 2^-24 D = 2^-16 R, 1/256 of a 512-texel
  footprint 2 R / 512).  The map covers the whole scene, so a scene much larger than the part in
  view (a ground plane far beyond a room) gets coarse texels: cascades fitted to the
  view are not done.

Each face is the rasterizer's own raster + resolve path (``primary.Rasterizer.find_hits``)
into a *hit-record target* (``HitRecordTarget``: the three hit-record channels, the
depth one a view of the map's face, so no surface pass runs and nothing is copied).
Casters are the opaque and cut-out triangles, cut-outs through the rasterizer's own
alpha test; emissive and transmissive triangles cast nothing (the tracer's shadow rays
pass through emitters and are only tinted by glass; a tinted shadow is not modelled),
their corners collapsed to one point in a copy of the index array the maps are drawn
with (``caster_scene``).

**Cache**: the maps are drawn again only when the device scene, its points
(``DeviceScene.geometry_version``), its materials (``materials_version``: which
triangles cast) or the lights' geometry (kind, position, direction, axes, radius, cone)
changed since the last drawing; a static scene draws them once, at warm-up or in its
first frame.  ``renders`` counts drawings.  The lookup is ``shadow_map_kernels``.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..core.camera import CameraGPU, make_camera_gpu
from ..core.gbuffer import GBuffer, GBufferRows
from ..core.passes import FrameContext, RenderPass
from ..parallel import Launcher
from ..primary import Rasterizer
from ..scene.device import DeviceScene
from ..scene.device.subset import hide_materials
from ..scene.model import Camera, Light, LightKind, Scene
from ..timing import StageTimer
from .shadow_map_kernels import ShadowMapsGPU, visibility_kernel

#: The default face size in texels (``RenderSettings.shadow_map_size``): 512 x 512 x 4
#: bytes = 1 MiB a face, 6 MiB a cube map.
DEFAULT_MAP_SIZE = 512
#: The face sizes accepted.
MIN_MAP_SIZE, MAX_MAP_SIZE = 16, 4096
#: A distant light's camera stands this many bounding radii from the scene's centre.
DISTANT_BACK = 256.0
#: A cube map's near plane as a share of its far one (when the light has no radius).
NEAR_FRACTION = 1.0e-6
#: Planes are moved this much (relative) outside the bounds they must hold.
MARGIN = 1.01


class HitRecordTarget:
    """What ``Rasterizer.find_hits`` writes, and only that: a ``size`` x ``size``
    triangle-id and barycentric scratch and a depth channel bound to one map face."""

    def __init__(self, size: int, device: wp.context.Device) -> None:
        """Allocate the scratch channels for ``size`` x ``size`` texels on ``device``."""
        self.width = self.height = size
        self._rows = GBufferRows()
        self._rows.triangle_id = wp.empty(size * size, dtype=wp.int32, device=device)
        self._rows.barycentric = wp.empty(size * size, dtype=wp.vec2, device=device)

    def bind(self, depth: wp.array) -> None:
        """Write depths into ``depth``, a contiguous (size, size) float32 face (texels
        no triangle covers keep what they hold: the caller clears it to inf)."""
        self._rows.depth = depth.reshape((-1,))

    def rows(self) -> GBufferRows:
        """The flat channels the resolve pass writes (the rest are unset)."""
        return self._rows


def caster_scene(scene: DeviceScene, previous: DeviceScene | None = None) -> DeviceScene:
    """``scene`` as the maps are drawn: the triangles that cast no shadow (emitters,
    ``Material.casts_shadow``) and the transmissive ones hidden
    (``scene.device.subset.hide_materials``)."""
    return hide_materials(scene, lambda m: not m.casts_shadow or m.is_transmissive, previous)


def light_geometry(light: Light) -> tuple[float, ...]:
    """What a light's map depends on (not its colour): kind, position, direction,
    axes, radius and cone."""
    values = (light.position, light.direction, light.axis_u, light.axis_v)
    return (
        float(light.kind),
        *np.asarray(values, dtype=np.float64).ravel().tolist(),
        light.radius,
        light.cone_angle_deg,
    )


def _basis(forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit (right, up) completing unit ``forward`` to a camera frame."""
    helper = np.array([0.0, 1.0, 0.0]) if abs(forward[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    right = np.cross(forward, helper)
    right /= np.linalg.norm(right)
    return right, np.cross(right, forward)


def face_camera(origin: np.ndarray, forward: np.ndarray, tan: float, near: float, far: float, size: int) -> CameraGPU:
    """The kernel camera at ``origin`` looking along unit ``forward`` (frame ``_basis``)
    with a square field of view of half-angle tangent ``tan``."""
    right, up = _basis(forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, up, -forward, origin
    aperture = 2.0 * tan
    return make_camera_gpu(Camera("/shadow_map", m, 1.0, aperture, aperture, near, far), size, size)


def _emits_one_side(light: Light) -> bool:
    """The light lights only the half space its ``direction`` faces."""
    return light.kind in (LightKind.RECT, LightKind.DISK) or light.cone_angle_deg <= 90.0


def light_faces(light: Light, scene: Scene, size: int) -> list[tuple[CameraGPU, bool]]:
    """Light ``light``'s face cameras in ``scene`` and whether each is drawn (module
    docstring): one for a distant light, the six cube faces otherwise."""
    lo, hi = scene.bounds
    centre = 0.5 * (lo + hi)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    if light.kind == LightKind.DISTANT:
        # The bounding box seen along the light: a square across it of half-size `half`
        # (the box is symmetric about its centre, so its projection is too) and depths
        # within `deep` of the centre's.
        forward = np.asarray(light.direction, dtype=np.float64)
        forward /= np.linalg.norm(forward)
        rel = corners - centre
        half = max(float(np.abs(rel @ np.stack(_basis(forward), axis=1)).max()) * MARGIN, 1e-30)
        deep = max(float(np.abs(rel @ forward).max()) * MARGIN, 1e-30)
        back = DISTANT_BACK * max(half, deep)
        camera = face_camera(centre - forward * back, forward, half / (back - deep), back - deep, back + deep, size)
        return [(camera, True)]
    origin = np.asarray(light.position, dtype=np.float64)
    far = max(float(np.linalg.norm(corners - origin, axis=1).max()) * MARGIN, 1e-30)
    near = max(light.radius if light.kind == LightKind.SPHERE else 0.0, NEAR_FRACTION * far)
    emits = np.asarray(light.direction, dtype=np.float64)
    faces = []
    for k in range(6):
        axis, sign = k // 2, 1.0 if k % 2 == 0 else -1.0
        forward = np.zeros(3)
        forward[axis] = sign
        # The face's directions are forward + a right + b up (|a|, |b| <= 1, right and
        # up the other two axes): some of them point to the emitting side when
        # sign emits[axis] + the other components' magnitudes > 0.
        reach = sign * emits[axis] + float(np.abs(np.delete(emits, axis)).sum())
        camera = face_camera(origin, forward, 1.0, near, max(far, 2.0 * near), size)
        faces.append((camera, reach > 0.0 or not _emits_one_side(light)))
    return faces


class ShadowMaps(RenderPass):
    """The "shadow_maps" stage: keeps every light's map current (module docstring)."""

    def __init__(self, launcher: Launcher, size: int = DEFAULT_MAP_SIZE) -> None:
        """Draw ``size`` x ``size``-texel faces on ``launcher``'s device and threads."""
        self.launcher = launcher
        self.size = size
        self.renders = 0
        self.gpu = ShadowMapsGPU()
        self._rasterizer = Rasterizer(launcher)
        self._target = HitRecordTarget(size, launcher.device)
        self._drawn_for: tuple | None = None
        self._casters: DeviceScene | None = None  # the last caster view, whose indices a new one may reuse

    def execute(self, frame: FrameContext) -> None:
        """Bring the maps up to date for the scene set with ``set_scene`` (timed)."""
        with frame.timer.stage("shadow_maps"):
            self.update()

    def update(self) -> bool:
        """Draw the maps again if what they depend on changed; True when drawn."""
        assert self.scene is not None, "set_scene first"
        scene = self.scene
        key = (
            scene,
            scene.geometry_version,
            scene.materials_version,
            [light_geometry(li) for li in scene.scene.lights],
        )
        if key == self._drawn_for:
            return False
        self._draw(scene)
        self._drawn_for = key
        self.renders += 1
        return True

    def _draw(self, scene: DeviceScene) -> None:
        """Render every light's faces into a (faces, size, size) depth array."""
        casters = self._casters = caster_scene(scene, self._casters)
        faces: list[tuple[CameraGPU, bool]] = []
        first = []
        for light in scene.scene.lights:
            first.append(len(faces))
            faces += light_faces(light, scene.scene, self.size)
        device = self.launcher.device
        shape = (max(len(faces), 1), self.size, self.size)
        if self.gpu.depth is None or tuple(self.gpu.depth.shape) != shape:
            self.gpu.depth = wp.empty(shape, dtype=wp.float32, device=device)
        self.gpu.depth.fill_(math.inf)
        timer = StageTimer()
        for k, (camera, drawn) in enumerate(faces):
            if drawn and scene.scene.triangle_count > 0:
                self._target.bind(self.gpu.depth[k])
                self._rasterizer.find_hits(casters, camera, self._target, timer)
        self.gpu.faces = wp.array([c for c, _ in faces] or [CameraGPU()], dtype=CameraGPU, device=device)
        self.gpu.first_face = wp.array(first or [0], dtype=wp.int32, device=device)

    def visibility(self, gbuffer: GBuffer) -> np.ndarray:
        """Diagnostic: (H, W, L) float32 shadow-map visibility of every light at each
        G-buffer pixel (NaN on background), from the current maps."""
        assert self.scene is not None, "set_scene first"
        gbuffer.require_geometric_normals("ShadowMaps.visibility")
        h, w = gbuffer.height, gbuffer.width
        out = wp.full(
            (h, w, len(self.scene.scene.lights)), value=math.nan, dtype=wp.float32, device=self.launcher.device
        )
        inputs = [self.scene.gpu, self.gpu, gbuffer.kernel_arrays(), out]
        self.launcher.launch_pixels(visibility_kernel, h, w, inputs)
        return out.numpy()
