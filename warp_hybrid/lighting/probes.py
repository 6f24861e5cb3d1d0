"""A reflection probe for the raster layer: the scene captured into a cube map by the
project's rasterizer, filtered into roughness levels, recaptured only when the scene
changes (stage "probes"; ``RenderSettings.probes``).  The lookup is ``probe_kernels``.

**Where** (``probe_position``): one probe, placed from the camera at capture (the
first frame, and the frame of each recapture; it does not follow the camera between
captures): the camera's own position when it stands inside the scene's bounds, else
the nearest point of the bounds shrunk by ``INSET`` of their extent on every side,
pulled back toward the camera in front of the first surface on the way (one ray;
``PULL_BACK``).  So the probe stands in free space the camera sees (the bounds' centre
may lie inside an object and capture its inside), and a room seen from outside (the
Cornell boxes' open side) is captured from within, where its walls are seen from the
side reflections look at them (and a reflection leaving by the open side looks out of
it, not along it).  The parallax box is the scene's bounds (grown by ``BOX_MARGIN``).

**Capture.** Six 90-degree faces of ``size`` x ``size`` texels (the shadow maps' face
cameras, ``shadow_maps.face_camera``), each drawn by ``primary.Rasterizer`` into a
small G-buffer (raster, resolve, surface) and shaded by the deferred lighting without a
probe: emission, direct light (shadowed through the shadow maps when they are on), the
dome's and the indirect estimate's ambient; no recursion (mirrors in the probe reflect
the dome only).  Texels that see no surface get coverage 0 and no radiance: the lookup
fills them with the dome (``probe_kernels``).

**Filtering** (on the host, from a read-back of 6 x size^2 texels, at each capture):
the dome's chain (``scene/device/dome.py``): area-averaged halvings of each face
(``dome.radiance_mips``) down to ``MIN_MIP_WIDTH`` texels, level l serving the GGX alpha
that matches its texel angle.  The probe stands in for the traced mirror ray, which
only surfaces smoother than ``SMOOTH_ROUGHNESS`` get (``probe_kernels``), so the
chain need not reach wider lobes: its last level, 8 texels across a face's 90 degrees
(alpha 0.196), serves that roughness (alpha 0.45^2 = 0.2).

**Cache**: captured again only when the device scene, its points
(``geometry_version``), materials (``materials_version``), textures, dome, indirect
estimate, lights (colour too: the probe holds their light) or the shadow maps changed;
``captures`` counts them, ``capture_ms`` is the last one's time.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer
from ..core.passes import FrameContext, RenderPass
from ..parallel import Launcher
from ..primary import Rasterizer
from ..scene.device import DeviceScene
from ..scene.device.dome import MIN_MIP_WIDTH, radiance_mips
from ..timing import StageTimer
from .deferred import DeferredLighting
from .probe_kernels import ProbeGPU, first_hit_kernel
from .shadow_maps import MARGIN, NEAR_FRACTION, ShadowMaps, face_camera

#: Texels a face side (6 x 64^2 x 16 bytes = 384 KiB at level 0).
PROBE_SIZE = 64
#: The parallax box is the scene's bounds grown by this share of their size.
BOX_MARGIN = 1.0e-3
#: A camera outside the bounds puts the probe this share of their extent inside them.
INSET = 0.1
#: A probe pulled back in front of a surface stands this share of the scene's size in
#: front of it (at most half way back to the camera).
PULL_BACK = 0.01


def theta0(size: int) -> float:
    """The angle of a level-0 texel at a face's centre, ``pi / (2 size)``."""
    return math.pi / (2.0 * size)


def level_sizes(size: int) -> list[int]:
    """Each level's face size: ``size`` halved down to ``MIN_MIP_WIDTH`` (as
    ``dome.radiance_mips``)."""
    sizes = [size]
    while sizes[-1] // 2 >= MIN_MIP_WIDTH:
        sizes.append(sizes[-1] // 2)
    return sizes


def probe_cameras(origin: np.ndarray, lo: np.ndarray, hi: np.ndarray, size: int) -> list[CameraGPU]:
    """The six face cameras at ``origin`` (``cube_face`` order) reaching every corner of
    the box ``lo``..``hi``."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    far = max(float(np.linalg.norm(corners - origin, axis=1).max()) * MARGIN, 1e-30)
    cameras = []
    for k in range(6):
        forward = np.zeros(3)
        forward[k // 2] = 1.0 if k % 2 == 0 else -1.0
        cameras.append(face_camera(origin, forward, 1.0, NEAR_FRACTION * far, far, size))
    return cameras


def filter_levels(faces: np.ndarray) -> list[np.ndarray]:
    """Every level (6, s, s, 4) of the captured ``faces`` (6, N, N, 4): each face's
    area-averaged mip chain (module docstring)."""
    chains = [[face, *radiance_mips(face, MIN_MIP_WIDTH)] for face in faces]
    return [np.stack([chain[k] for chain in chains]) for k in range(len(chains[0]))]


def probe_position(scene: DeviceScene, camera: np.ndarray) -> np.ndarray:
    """Where the probe stands for a camera at ``camera`` (local frame; module docstring)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.scene.bounds)
    if np.all(camera >= lo) and np.all(camera <= hi):
        return camera
    inset = INSET * (hi - lo)
    target = np.clip(camera, lo + inset, hi - inset)
    offset = target - camera
    length = float(np.linalg.norm(offset))
    if length == 0.0 or scene.warp_bvh() is None:
        return target
    direction = offset / length
    t = wp.zeros(1, dtype=float, device=scene.device)
    inputs = [scene.gpu.mesh, wp.vec3(*camera.tolist()), wp.vec3(*direction.tolist()), length, t]
    wp.launch(first_hit_kernel, dim=1, inputs=inputs, device=scene.device)
    hit = float(t.numpy()[0])
    if hit < 0.0:
        return target
    return camera + direction * max(hit - PULL_BACK * float(np.max(hi - lo)), 0.5 * hit)


def capture_key(scene: DeviceScene, maps: ShadowMaps | None) -> tuple[tuple, tuple]:
    """What a capture depends on: (values compared with ==, objects compared by identity)."""
    env = scene.scene.environment
    dome = None if env is None else (tuple(env.color), env.texture, np.asarray(env.world_to_light).tolist())
    values = (
        scene.geometry_version,
        scene.materials_version,
        list(scene.scene.lights),
        dome,
        tuple(scene.ambient.indirect),
        maps.renders if maps is not None else 0,
    )
    return values, (scene, scene.ambient, scene.texels)


class ReflectionProbe(RenderPass):
    """The "probes" stage: keeps the raster layer's reflection probe current (module
    docstring); ``gpu`` is what the lighting kernel reads."""

    def __init__(self, launcher: Launcher, shadow_maps: ShadowMaps | None = None, size: int = PROBE_SIZE) -> None:
        """Capture ``size``-texel faces on ``launcher``'s device and threads, shadowed by
        ``shadow_maps`` when given (their pass runs before this one)."""
        self.launcher = launcher
        self.size = size
        self.shadow_maps = shadow_maps
        self.captures = 0
        self.capture_ms = 0.0
        self.gpu = ProbeGPU()
        self._rasterizer = Rasterizer(launcher)
        self._lighting = DeferredLighting(launcher, shadow_maps)
        self._gbuffer = GBuffer(size, size, launcher.device)
        self._color = wp.empty((size, size), dtype=wp.vec3, device=launcher.device)
        self._captured_for: tuple[tuple, tuple] | None = None

    def execute(self, frame: FrameContext) -> None:
        """Bring the probe up to date for the scene set with ``set_scene`` (timed),
        capturing from the frame camera's position when it must."""
        with frame.timer.stage("probes"):
            self.update(np.array(list(frame.camera.origin), dtype=np.float64))

    def update(self, camera: np.ndarray) -> bool:
        """Capture the probe for a camera at ``camera`` (local frame; ``probe_position``)
        if what it depends on changed; True when captured."""
        assert self.scene is not None, "set_scene first"
        key = capture_key(self.scene, self.shadow_maps)
        known = self._captured_for
        if known is not None and known[0] == key[0] and all(a is b for a, b in zip(known[1], key[1])):
            return False
        timer = StageTimer()
        with timer.stage("capture"):
            self.capture(self.scene, probe_position(self.scene, camera))
        self.capture_ms = timer.total_ms
        self._captured_for = key
        self.captures += 1
        return True

    def capture(self, scene: DeviceScene, origin: np.ndarray) -> None:
        """Draw and shade the six faces of ``scene`` seen from ``origin`` (local frame),
        filter them and upload the probe into ``gpu``."""
        lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.scene.bounds)
        lo, hi = np.minimum(lo, origin), np.maximum(hi, origin)
        grow = BOX_MARGIN * max(float(np.max(hi - lo)), 1e-30)
        lo, hi = lo - grow, hi + grow
        cameras = probe_cameras(origin, lo, hi, self.size)
        maps = self.shadow_maps.gpu if self.shadow_maps is not None else None
        faces = np.zeros((6, self.size, self.size, 4), dtype=np.float32)
        timer = StageTimer()
        for k, camera in enumerate(cameras):
            if scene.scene.triangle_count == 0:
                break
            self._rasterizer.render(scene, camera, self._gbuffer, timer)
            self._lighting.shade(scene, camera, self._gbuffer, self._color, timer, maps)
            covered = (self._gbuffer.triangle_id.numpy() >= 0).astype(np.float32)
            faces[k, ..., :3] = self._color.numpy() * covered[..., None]
            faces[k, ..., 3] = covered
        levels = filter_levels(faces)
        device = self.launcher.device
        sizes = [level.shape[1] for level in levels]
        offsets = np.cumsum([0] + [level[..., 0].size for level in levels])[:-1]
        g = ProbeGPU()
        g.faces = wp.array(cameras, dtype=CameraGPU, device=device)
        flat = np.concatenate([level.reshape(-1, 4) for level in levels])
        g.texels = wp.array(np.ascontiguousarray(flat, dtype=np.float32), dtype=wp.vec4, device=device)
        g.offset = wp.array(np.asarray(offsets, dtype=np.int32), dtype=wp.int32, device=device)
        g.size = wp.array(np.asarray(sizes, dtype=np.int32), dtype=wp.int32, device=device)
        g.levels = len(levels)
        g.inv_theta0 = 1.0 / theta0(self.size)
        g.origin = wp.vec3(*origin.tolist())
        g.box_lo = wp.vec3(*lo.tolist())
        g.box_hi = wp.vec3(*hi.tolist())
        self.gpu = g
