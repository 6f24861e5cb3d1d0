"""Device-resident scene: flat Warp arrays, material/texture/light tables, the BVH.

Built once from a host ``Scene`` and reused every frame.  ``SceneGPU`` is a single
Warp struct that every kernel takes, so kernel signatures stay short.  When animated
points move, ``DeviceScene.update`` copies the new points and normals and *refits*
the ``wp.Mesh`` BVH instead of rebuilding it.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..timing import StageTimer
from .features import analyse_features
from .mipmaps import mip_chain
from .model import Camera, Scene

# Material flag bits (MaterialGPU.flags).
FLAG_SPECULAR_WORKFLOW = wp.constant(1)
FLAG_THIN_WALLED = wp.constant(2)
FLAG_DOUBLE_SIDED = wp.constant(4)
FLAG_TRANSMISSIVE = wp.constant(8)
FLAG_REFRACTIVE = wp.constant(16)
FLAG_CUTOUT = wp.constant(32)


@wp.struct
class MaterialGPU:
    """UsdPreviewSurface parameters as kernels see them (texture slots: -1 = none)."""

    diffuse: wp.vec3
    emissive: wp.vec3
    specular: wp.vec3
    attenuation_color: wp.vec3
    attenuation_distance: float
    metallic: float
    roughness: float
    opacity: float
    opacity_threshold: float
    ior: float
    flags: int
    diffuse_tex: int
    emissive_tex: int
    roughness_tex: int
    roughness_channel: int
    metallic_tex: int
    metallic_channel: int
    opacity_tex: int
    opacity_channel: int


# Longest mip chain kept (level 15 of a 32768-texel image is 1 texel wide).
MAX_MIP_LEVELS = 16
MipOffsets = wp.types.vector(length=MAX_MIP_LEVELS, dtype=wp.int32)


@wp.struct
class TextureGPU:
    """One UsdUVTexture binding: where its image starts in ``texels`` and how to sample.

    ``offset``, ``width`` and ``height`` describe mip level 0 (the image itself);
    ``levels`` counts its mip chain (1 when none was built), level L being
    ``max(1, width >> L)`` x ``max(1, height >> L)`` texels at ``level_offsets[L]``
    (see ``mipmaps``; entries past the chain repeat its last level)."""

    offset: int
    width: int
    height: int
    levels: int
    level_offsets: MipOffsets
    wrap_s: int
    wrap_t: int
    scale: wp.vec4
    bias: wp.vec4


@wp.struct
class LightGPU:
    """One UsdLux light (see ``model.Light``); angles are pre-converted to cosines."""

    kind: int
    color: wp.vec3
    position: wp.vec3
    direction: wp.vec3
    axis_u: wp.vec3
    axis_v: wp.vec3
    radius: float
    cos_half_angle: float
    cos_cone: float
    cone_softness: float
    normalize: int


@wp.struct
class EnvironmentGPU:
    """The dome light: constant colour times an optional lat-long texture."""

    enabled: int
    color: wp.vec3
    texture: int
    world_to_light: wp.mat33


@wp.struct
class CameraGPU:
    """A pinhole camera for one image size.

    The ray through pixel centre (x + 0.5, y + 0.5), with row 0 at the top, is
    ``forward + ndc_x * tan_x * right + ndc_y * tan_y * up`` with
    ``ndc_x = 2 (x + 0.5) / width - 1`` and ``ndc_y = 1 - 2 (y + 0.5) / height``.
    View depth is the distance along ``forward``.
    """

    origin: wp.vec3
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    tan_x: float
    tan_y: float
    width: int
    height: int
    near: float
    far: float


@wp.struct
class SceneGPU:
    """Everything a kernel needs to know about the scene."""

    mesh: wp.uint64
    points: wp.array(dtype=wp.vec3)
    indices: wp.array(dtype=wp.int32)
    corner_normals: wp.array(dtype=wp.vec3)
    corner_uvs: wp.array(dtype=wp.vec2)
    triangle_material: wp.array(dtype=wp.int32)
    materials: wp.array(dtype=MaterialGPU)
    textures: wp.array(dtype=TextureGPU)
    texels: wp.array(dtype=wp.vec4)
    lights: wp.array(dtype=LightGPU)
    light_count: int
    environment: EnvironmentGPU


def make_camera_gpu(camera: Camera, width: int, height: int) -> CameraGPU:
    """Build the kernel-side camera for an image of ``width`` x ``height`` pixels."""
    m = np.asarray(camera.cam_to_world, dtype=np.float64)
    right = m[:3, 0] / np.linalg.norm(m[:3, 0])
    up = m[:3, 1] / np.linalg.norm(m[:3, 1])
    forward = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    c = CameraGPU()
    c.origin = wp.vec3(*m[:3, 3].tolist())
    c.right = wp.vec3(*right.tolist())
    c.up = wp.vec3(*up.tolist())
    c.forward = wp.vec3(*forward.tolist())
    c.tan_x = float(camera.tan_half_fov_x)
    c.tan_y = float(camera.tan_half_fov_y(width, height))
    c.width = int(width)
    c.height = int(height)
    c.near = float(camera.near)
    c.far = float(camera.far)
    return c


def _material_images(scene: Scene) -> set[int]:
    """Indices of the images some material samples (those get mip chains; an image
    only the dome light uses is looked up unfiltered and needs none)."""
    used = set()
    for m in scene.materials:
        for slot in (m.diffuse_texture, m.emissive_texture, m.roughness_texture, m.metallic_texture, m.opacity_texture):
            if 0 <= slot < len(scene.textures):
                used.add(scene.textures[slot].image)
    return used


def _struct_array(items: list, dtype: type, device: wp.context.Device) -> wp.array:
    """A Warp array of structs; never empty (a default element pads an empty list,
    the real count travels separately), since kernels cannot take 0-length tables."""
    return wp.array(items if items else [dtype()], dtype=dtype, device=device)


def _vec3(t: tuple[float, float, float] | np.ndarray) -> wp.vec3:
    return wp.vec3(float(t[0]), float(t[1]), float(t[2]))


def _material_gpu(m) -> MaterialGPU:
    g = MaterialGPU()
    g.diffuse = _vec3(m.diffuse)
    g.emissive = _vec3(m.emissive)
    g.specular = _vec3(m.specular)
    g.attenuation_color = _vec3(m.attenuation_color)
    g.attenuation_distance = float(min(m.attenuation_distance, 3.0e38))
    g.metallic = float(m.metallic)
    g.roughness = float(m.roughness)
    g.opacity = float(m.opacity)
    g.opacity_threshold = float(m.opacity_threshold)
    g.ior = float(m.ior)
    bits = (
        (FLAG_SPECULAR_WORKFLOW, m.use_specular_workflow),
        (FLAG_THIN_WALLED, m.thin_walled),
        (FLAG_DOUBLE_SIDED, m.double_sided),
        (FLAG_TRANSMISSIVE, m.is_transmissive),
        (FLAG_REFRACTIVE, m.is_refractive),
        (FLAG_CUTOUT, m.is_cutout),
    )
    g.flags = sum(int(bit) for bit, on in bits if on)
    g.diffuse_tex = int(m.diffuse_texture)
    g.emissive_tex = int(m.emissive_texture)
    g.roughness_tex = int(m.roughness_texture)
    g.roughness_channel = int(m.roughness_channel)
    g.metallic_tex = int(m.metallic_texture)
    g.metallic_channel = int(m.metallic_channel)
    g.opacity_tex = int(m.opacity_texture)
    g.opacity_channel = int(m.opacity_channel)
    return g


def _light_gpu(light) -> LightGPU:
    g = LightGPU()
    g.kind = int(light.kind)
    g.color = _vec3(light.color)
    g.position = _vec3(light.position)
    d = np.asarray(light.direction, dtype=np.float64)
    n = np.linalg.norm(d)
    g.direction = _vec3(d / n if n > 0 else np.array([0.0, 0.0, -1.0]))
    g.axis_u = _vec3(light.axis_u)
    g.axis_v = _vec3(light.axis_v)
    g.radius = float(light.radius)
    g.cos_half_angle = float(math.cos(math.radians(0.5 * light.angle_deg)))
    g.cos_cone = float(math.cos(math.radians(min(light.cone_angle_deg, 180.0))))
    g.cone_softness = float(light.cone_softness)
    g.normalize = 1 if light.normalize else 0
    return g


class DeviceScene:
    """A ``Scene`` uploaded to one Warp device, with its BVH."""

    def __init__(self, scene: Scene, device: wp.context.Device | str = "cpu", timer: StageTimer | None = None) -> None:
        """Upload ``scene`` to ``device`` and build the BVH (once); ``timer`` gets the
        stages "upload" and "bvh_build"."""
        timer = timer or StageTimer()
        self.device = wp.get_device(device)
        with timer.stage("upload"):
            self._upload(scene)
        with timer.stage("bvh_build"):
            self.mesh = wp.Mesh(points=self.points, indices=self.indices) if scene.triangle_count > 0 else None
        self.gpu = self._make_struct()

    def _upload(self, scene: Scene) -> None:
        self.scene = scene
        self.features = analyse_features(scene)
        d = self.device
        self.points = wp.array(np.ascontiguousarray(scene.points, dtype=np.float32), dtype=wp.vec3, device=d)
        self.indices = wp.array(
            np.ascontiguousarray(scene.indices.reshape(-1), dtype=np.int32), dtype=wp.int32, device=d
        )
        self.corner_normals = wp.array(
            np.ascontiguousarray(scene.corner_normals.reshape(-1, 3), dtype=np.float32), dtype=wp.vec3, device=d
        )
        self.corner_uvs = wp.array(
            np.ascontiguousarray(scene.corner_uvs.reshape(-1, 2), dtype=np.float32), dtype=wp.vec2, device=d
        )
        self.triangle_material = wp.array(
            np.ascontiguousarray(scene.triangle_material, dtype=np.int32), dtype=wp.int32, device=d
        )
        self.materials = _struct_array([_material_gpu(m) for m in scene.materials], MaterialGPU, d)
        texels, tex_structs = self._pack_textures(scene)
        # copy=False: on the CPU the packed array itself becomes the device array.
        self.texels = wp.array(texels, dtype=wp.vec4, device=d, copy=False)
        self.textures = _struct_array(tex_structs, TextureGPU, d)
        self.lights = _struct_array([_light_gpu(li) for li in scene.lights], LightGPU, d)

    @staticmethod
    def _pack_textures(scene: Scene) -> tuple[np.ndarray, list[TextureGPU]]:
        """Flat texels of every image (with its mip chain when a material samples it,
        so minified lookups can pick a level) and one ``TextureGPU`` per binding."""
        mipped = _material_images(scene)
        chains = [
            mip_chain(img.pixels)[:MAX_MIP_LEVELS] if k in mipped else [img.pixels]
            for k, img in enumerate(scene.images)
        ]
        level_offsets = []
        total = 0
        for chain in chains:
            starts = []
            for level in chain:
                starts.append(total)
                total += level.shape[0] * level.shape[1]
            level_offsets.append(starts + [starts[-1]] * (MAX_MIP_LEVELS - len(starts)))
        texels = np.zeros((max(total, 1), 4), dtype=np.float32)
        for chain, starts in zip(chains, level_offsets):
            for level, start in zip(chain, starts):
                texels[start : start + level.shape[0] * level.shape[1]] = level.reshape(-1, 4)
        structs = []
        for t in scene.textures:
            g = TextureGPU()
            img = scene.images[t.image]
            g.offset = level_offsets[t.image][0]
            g.width = img.width
            g.height = img.height
            g.levels = len(chains[t.image])
            g.level_offsets = MipOffsets(*level_offsets[t.image])
            g.wrap_s = int(t.wrap_s)
            g.wrap_t = int(t.wrap_t)
            g.scale = wp.vec4(*[float(v) for v in t.scale])
            g.bias = wp.vec4(*[float(v) for v in t.bias])
            structs.append(g)
        return texels, structs

    def _make_struct(self) -> SceneGPU:
        s = SceneGPU()
        s.mesh = wp.uint64(self.mesh.id if self.mesh is not None else 0)
        s.points = self.points
        s.indices = self.indices
        s.corner_normals = self.corner_normals
        s.corner_uvs = self.corner_uvs
        s.triangle_material = self.triangle_material
        s.materials = self.materials
        s.textures = self.textures
        s.texels = self.texels
        s.lights = self.lights
        s.light_count = len(self.scene.lights)
        env = EnvironmentGPU()
        e = self.scene.environment
        env.enabled = 1 if e is not None else 0
        env.color = _vec3(e.color) if e is not None else wp.vec3(0.0, 0.0, 0.0)
        env.texture = int(e.texture) if e is not None else -1
        m = np.asarray(e.world_to_light if e is not None else np.eye(3), dtype=np.float32)
        env.world_to_light = wp.mat33(*m.reshape(-1).tolist())
        s.environment = env
        return s

    def update(self, scene: Scene) -> None:
        """Take the moved points/normals of an animated ``scene`` (same topology) and
        refit the BVH instead of rebuilding it.  Lights and cameras are replaced too."""
        if scene.indices.shape != self.scene.indices.shape or not np.array_equal(scene.indices, self.scene.indices):
            raise ValueError("DeviceScene.update needs the same topology; build a new DeviceScene instead")
        self.points.assign(np.ascontiguousarray(scene.points, dtype=np.float32))
        self.corner_normals.assign(np.ascontiguousarray(scene.corner_normals.reshape(-1, 3), dtype=np.float32))
        if len(scene.lights) == len(self.scene.lights):
            self.lights = _struct_array([_light_gpu(li) for li in scene.lights], LightGPU, self.device)
        self.scene = scene
        if self.mesh is not None:
            self.mesh.refit()
        self.gpu = self._make_struct()
