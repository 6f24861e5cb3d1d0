"""The device-resident scene: flat Warp arrays, material/texture/light tables, the BVH,
and the dome's ambient data.

Built once from a host ``Scene``.  ``SceneGPU`` (``core/scene_gpu.py``) is the single
struct kernels take.  ``DeviceScene.update`` takes the same scene at another time: it
copies moved points and normals and *refits* the BVHs instead of rebuilding them (the
4-wide copy at once, only where the points moved; Warp's own tree when a pass next
queries it, ``warp_bvh``), re-uploads lights, materials, textures and the dome when
they changed, re-analyses the features, and refuses clearly when the topology changed.
``geometry_version`` counts point updates and ``materials_version`` material uploads,
so passes that keep derived data (the tracer's shadow meshes) know when to refit or
rebuild theirs; ``content_version`` counts the updates that changed anything a frame
draws (points, normals, colours, lights, materials, textures, the dome), so a renderer
that keeps a still view's raster layer knows when it is stale; ``moved`` says where,
when the last update moved geometry alone (``MovedGeometry``: the box around the
triangles that changed), so such a renderer can draw only the rows that box projects to.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from ...core.features import SceneFeatures, analyse_features
from ...core.native_rows import spare_padded
from ...core.scene_gpu import (
    FLAG_BLENDED,
    FLAG_CUTOUT,
    FLAG_REFRACTIVE,
    FLAG_SPECULAR_WORKFLOW,
    FLAG_TRANSMISSIVE,
    FLAG_VERTEX_COLOR,
    MAX_MIP_LEVELS,
    MAX_TEXEL_FLOATS,
    AmbientGPU,
    EnvironmentGPU,
    LightGPU,
    MaterialGPU,
    MipOffsets,
    SceneGPU,
    TextureGPU,
)
from ...errors import SceneError
from ...lighting.indirect import indirect_irradiance
from ...timing import StageTimer
from ..model import Light, Material, Scene
from .dome import build_ambient, dome_source, same_dome
from .mipmaps import mip_chain
from .triangle_bound import triangle_bounds
from .wide_bvh import WideBVH


@dataclasses.dataclass(frozen=True)
class MovedGeometry:
    """What the last ``DeviceScene.update`` changed, where that was geometry alone (points
    and normals): it took ``content_version`` from ``since`` to ``since + 1``, and every
    triangle that changed lies, before and after, within the box ``lo``..``hi`` (the
    scene's local frame).  A view whose raster layer was drawn at ``since`` is stale only
    where that box projects."""

    since: int
    lo: np.ndarray
    hi: np.ndarray


def _rows_differ(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row (first index) of two arrays of one shape, whether any of its values differs
    (one flat comparison, then the rows of the values that differ: numpy's ``any`` over
    rows of a few values is many times slower)."""
    rows = np.zeros(len(a), dtype=bool)
    if len(a):
        rows[np.flatnonzero(np.ravel(a) != np.ravel(b)) // (a.size // len(a))] = True
    return rows


def _moved_box(old: Scene, new: Scene) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """The points that moved between ``old`` and ``new`` (same topology; a bool each), and
    the box around the triangles whose corners moved or whose normals changed, at both
    times (None where none did)."""
    if new.points is old.points:
        moved = np.zeros(len(new.points), dtype=bool)
    else:
        moved = _rows_differ(new.points, old.points)
    changed = moved
    if new.corner_normals is not old.corner_normals:
        triangles = np.flatnonzero(_rows_differ(new.corner_normals, old.corner_normals))  # (T, 3, 3): a row a triangle
        if len(triangles):
            changed = moved.copy()
            changed[np.asarray(new.indices).reshape(-1, 3)[triangles].ravel()] = True
    changed = np.flatnonzero(changed)
    if not len(changed):
        return moved, None
    both = np.concatenate([old.points[changed], new.points[changed]]).astype(np.float64)
    return moved, (both.min(axis=0), both.max(axis=0))


def _struct_array(items: list, dtype: type, device: wp.context.Device) -> wp.array:
    """A Warp array of structs; never empty (a default element pads an empty list,
    the real count travels separately), since kernels cannot take 0-length tables."""
    return wp.array(items if items else [dtype()], dtype=dtype, device=device)


def _vec3(t: tuple[float, float, float] | np.ndarray) -> wp.vec3:
    return wp.vec3(float(t[0]), float(t[1]), float(t[2]))


def material_flags(m: Material) -> int:
    """The ``FLAG_*`` bits of a material (the host predicates kernels test as bits)."""
    bits = (
        (FLAG_SPECULAR_WORKFLOW, m.use_specular_workflow),
        (FLAG_TRANSMISSIVE, m.is_glass),
        (FLAG_BLENDED, m.is_blended),
        (FLAG_REFRACTIVE, m.is_refractive),
        (FLAG_CUTOUT, m.is_cutout),
        (FLAG_VERTEX_COLOR, m.is_vertex_colored),
    )
    return sum(int(bit) for bit, on in bits if on)


def _material_gpu(m: Material) -> MaterialGPU:
    g = MaterialGPU()
    g.diffuse = _vec3(m.diffuse)
    g.emissive = _vec3(m.emissive)
    g.specular = _vec3(m.specular)
    g.metallic = float(m.metallic)
    g.roughness = float(m.roughness)
    g.opacity = float(m.opacity)
    g.opacity_threshold = float(m.opacity_threshold)
    g.ior = float(m.ior)
    g.flags = material_flags(m)
    g.diffuse_tex = int(m.diffuse_texture)
    g.emissive_tex = int(m.emissive_texture)
    g.roughness_tex = int(m.roughness_texture)
    g.roughness_channel = int(m.roughness_channel)
    g.metallic_tex = int(m.metallic_texture)
    g.metallic_channel = int(m.metallic_channel)
    g.opacity_tex = int(m.opacity_texture)
    g.opacity_channel = int(m.opacity_channel)
    g.normal_tex = int(m.normal_texture)
    return g


def _light_gpu(light: Light) -> LightGPU:
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


def _material_images(scene: Scene) -> set[int]:
    """Indices of the images some material samples (those get mip chains; an image
    only the dome light uses is looked up unfiltered and needs none)."""
    return {
        scene.textures[slot].image
        for m in scene.materials
        for slot in m.texture_slots()
        if 0 <= slot < len(scene.textures)
    }


def _texture_source(scene: Scene) -> tuple:
    """What the packed texels are derived from (bindings by value, images by identity)."""
    return tuple(scene.textures), tuple(id(img.pixels) for img in scene.images), frozenset(_material_images(scene))


def pack_textures(scene: Scene) -> tuple[np.ndarray, list[TextureGPU]]:
    """Flat texels of every image (with its mip chain when a material samples it, so
    minified lookups can pick a level) and one ``TextureGPU`` per binding; a
    ``SceneError`` where the texels would pass ``MAX_TEXEL_FLOATS``."""
    mipped = _material_images(scene)
    chains = [
        mip_chain(img.pixels)[:MAX_MIP_LEVELS] if k in mipped else [img.pixels] for k, img in enumerate(scene.images)
    ]
    level_offsets = []
    total = 0
    for chain in chains:
        starts = []
        for level in chain:
            starts.append(total)
            total += level.shape[0] * level.shape[1]
        level_offsets.append(starts + [starts[-1]] * (MAX_MIP_LEVELS - len(starts)))
    if 4 * total > MAX_TEXEL_FLOATS:
        raise SceneError(
            scene.path,
            f"its {len(scene.images)} texture images hold {total} texels with their mip chains; "
            f"at most {MAX_TEXEL_FLOATS // 4} fit the renderer's 32-bit texel indices",
        )
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
        a, b, c, d, e, f = (float(v) for v in t.uv_transform)
        g.uv_u = wp.vec3(a, b, c)
        g.uv_v = wp.vec3(d, e, f)
        structs.append(g)
    return texels, structs


def _environment_gpu(scene: Scene) -> EnvironmentGPU:
    env = EnvironmentGPU()
    e = scene.environment
    env.enabled = 1 if e is not None else 0
    env.color = _vec3(e.color) if e is not None else wp.vec3(0.0, 0.0, 0.0)
    env.texture = int(e.texture) if e is not None else -1
    m = np.asarray(e.world_to_light if e is not None else np.eye(3), dtype=np.float32)
    env.world_to_light = wp.mat33(*m.reshape(-1).tolist())
    return env


def _same_array(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal arrays: the same object (a source returns its unchanged arrays
    themselves, read-only) or equal elements."""
    return a is b or np.array_equal(a, b)


def _f32(a: np.ndarray, width: int) -> np.ndarray:
    return np.ascontiguousarray(a.reshape(-1, width), dtype=np.float32)


def _corner_colors(scene: Scene) -> np.ndarray:
    """The per-corner colours as flat rgb rows; one black row when the scene has none
    (kernels cannot take empty arrays).  Raises ``SceneError`` when a vertex-coloured
    material would read colours the scene does not hold (a kernel would read out of bounds)."""
    if scene.corner_colors.size:
        if scene.corner_colors.shape != (scene.triangle_count, 3, 3):
            raise SceneError(scene.path, f"corner_colors has shape {scene.corner_colors.shape}, expected (T, 3, 3)")
        return _f32(scene.corner_colors, 3)
    coloured = [m.name for m in scene.materials if m.is_vertex_colored]
    if coloured:
        raise SceneError(scene.path, f"material {coloured[0]} reads corner colours but the scene has none")
    return np.zeros((1, 3), dtype=np.float32)


class DeviceScene:
    """A ``Scene`` uploaded to one Warp device, with its BVH and dome data.

    ``view_of`` and ``hidden_materials`` are set on the views ``subset.hide_materials``
    makes (the scene a view shows part of, and its per-material hidden mask)."""

    view_of: DeviceScene | None = None
    hidden_materials: np.ndarray | None = None

    def __init__(
        self,
        scene: Scene,
        device: wp.context.Device | str = "cpu",
        timer: StageTimer | None = None,
        indirect: bool = False,
    ) -> None:
        """Upload ``scene`` to ``device`` and build the BVH (once); ``timer`` gets the
        stages "upload" and "bvh_build".  ``indirect``: add the lights' interreflection
        estimate (``lighting/indirect.py``) to the diffuse ambient of every pass."""
        timer = timer or StageTimer()
        self.device = wp.get_device(device)
        self.geometry_version = 0
        self.materials_version = 0
        self.content_version = 0
        #: The last update's change, where it was geometry alone (else None).
        self.moved: MovedGeometry | None = None
        #: The points the update to ``geometry_version`` moved (a bool each; None before the
        #: first): a BVH over these points refitted at the version before it refits only theirs.
        self.moved_points: np.ndarray | None = None
        self.indirect = bool(indirect)
        with timer.stage("upload"):
            self.scene = scene
            self._indirect_e = self._indirect_estimate(scene)
            self.features = self._features(scene)
            d = self.device
            # (with a spare point after the last: the surface loop loads a point as four floats)
            points = _f32(scene.points, 3)
            self.points = spare_padded(len(points), wp.vec3, d)
            self.points.assign(points)
            self.indices = wp.array(np.ascontiguousarray(scene.indices.reshape(-1), np.int32), dtype=wp.int32, device=d)
            self.triangle_bound = triangle_bounds(self.points, self.indices)
            self.corner_normals = wp.array(_f32(scene.corner_normals, 3), dtype=wp.vec3, device=d)
            self.corner_uvs = wp.array(_f32(scene.corner_uvs, 2), dtype=wp.vec2, device=d)
            self.corner_colors = wp.array(_corner_colors(scene), dtype=wp.vec3, device=d)
            self.triangle_material = wp.array(
                np.ascontiguousarray(scene.triangle_material, np.int32), dtype=wp.int32, device=d
            )
            self._upload_materials(scene)
            self._upload_textures(scene)
            self._upload_lights(scene)
            self._upload_dome(scene)
        with timer.stage("bvh_build"):
            self.mesh = wp.Mesh(points=self.points, indices=self.indices) if scene.triangle_count > 0 else None
        self._wide: WideBVH | None = None
        self._no_wide: WideBVH | None = None
        self._warp_bvh_stale = False
        self.gpu = self._make_struct()

    @property
    def wide_bvh(self) -> WideBVH:
        """The 4-wide copy of ``mesh`` (``wide_bvh.py``), built on first use and refitted with
        the mesh from then on; empty on CUDA, whose queries are Warp's own."""
        if self._wide is None:
            cpu_mesh = self.mesh if self.device.is_cpu else None
            self._wide = WideBVH(cpu_mesh, self.scene.triangle_count if cpu_mesh is not None else 0, self.device)
        return self._wide

    def warp_bvh(self) -> wp.Mesh | None:
        """``mesh``, its BVH (Warp's own tree) following the current points: refitted here
        when an update moved them since.  A pass whose kernels query ``mesh`` (``gpu.mesh``)
        with Warp's queries calls this before it launches them.  The 4-wide copies are
        refitted by every update, so a CPU frame that queries only those (the default)
        never pays for Warp's refit."""
        if self._warp_bvh_stale and self.mesh is not None:
            self.mesh.refit()
        self._warp_bvh_stale = False
        return self.mesh

    def query_bvh(self, wide: bool) -> WideBVH:
        """The copy a pass that queries the scene passes to its kernels: ``wide_bvh``
        with ``wide`` (``wide_bvh.use_wide_bvh``), else an empty one, whose kernels then
        use Warp's own query on ``mesh`` (made current here, ``warp_bvh``)."""
        if wide:
            return self.wide_bvh
        self.warp_bvh()
        if self._no_wide is None:
            self._no_wide = WideBVH(None, 0, self.device)
        return self._no_wide

    def _upload_materials(self, scene: Scene) -> None:
        self.materials = _struct_array([_material_gpu(m) for m in scene.materials], MaterialGPU, self.device)
        self.materials_version += 1

    def _upload_textures(self, scene: Scene) -> None:
        texels, structs = pack_textures(scene)
        # copy=False: on the CPU the packed array itself becomes the device array.
        self.texels = wp.array(texels, dtype=wp.vec4, device=self.device, copy=False)
        self.textures = _struct_array(structs, TextureGPU, self.device)
        self._texture_source = _texture_source(scene)

    def _upload_lights(self, scene: Scene) -> None:
        self.lights = _struct_array([_light_gpu(li) for li in scene.lights], LightGPU, self.device)

    def _upload_dome(self, scene: Scene) -> None:
        self.ambient: AmbientGPU = build_ambient(scene, self.device)
        self._dome_source = dome_source(scene)
        self.ambient.indirect = wp.vec3(*self._indirect_e)

    def _indirect_estimate(self, scene: Scene) -> tuple[float, float, float]:
        """The lights' indirect irradiance (``lighting/indirect.py``) where the estimate
        is on, else zero."""
        if not self.indirect:
            return (0.0, 0.0, 0.0)
        e = indirect_irradiance(scene)
        return (float(e[0]), float(e[1]), float(e[2]))

    def _features(self, scene: Scene) -> SceneFeatures:
        """The scene's effects, ``indirect`` among them where the estimate gives light."""
        features = analyse_features(scene)
        if max(self._indirect_e) > 0.0:
            features = dataclasses.replace(features, indirect=True)
        return features

    def _make_struct(self) -> SceneGPU:
        s = SceneGPU()
        s.mesh = wp.uint64(self.mesh.id if self.mesh is not None else 0)
        s.points = self.points
        s.indices = self.indices
        s.triangle_bound = self.triangle_bound
        s.corner_normals = self.corner_normals
        s.corner_uvs = self.corner_uvs
        s.corner_colors = self.corner_colors
        s.triangle_material = self.triangle_material
        s.materials = self.materials
        s.textures = self.textures
        s.texels = self.texels
        s.lights = self.lights
        s.light_count = len(self.scene.lights)
        s.environment = _environment_gpu(self.scene)
        return s

    def update(self, scene: Scene) -> None:
        """Take ``scene``, the same scene at another time: copy moved points and normals
        and refit the BVH; re-upload the lights, and the materials, textures and dome
        where they changed; re-analyse the features.  Raises ``SceneError`` when the
        topology (triangles, their materials) differs: build a new ``DeviceScene``."""
        old = self.scene
        if (
            scene.indices.shape != old.indices.shape
            or scene.points.shape != old.points.shape
            or not _same_array(scene.indices, old.indices)
            or not _same_array(scene.triangle_material, old.triangle_material)
        ):
            raise SceneError(
                scene.path,
                f"the topology changed between time {old.time} and {scene.time} "
                f"({old.triangle_count} -> {scene.triangle_count} triangles); build a new DeviceScene instead",
            )
        changed = False
        since = self.content_version
        moved_points, box = _moved_box(old, scene)
        elsewhere = False  # something drawn changed beyond the box: colours, lights, materials, images
        if moved_points.any():
            self.points.assign(_f32(scene.points, 3))
            triangle_bounds(self.points, self.indices, self.triangle_bound)
            self._warp_bvh_stale = True  # refitted by the first pass that queries it (``warp_bvh``)
            if self._wide is not None:
                self._wide.refit(moved_points)
            self.geometry_version += 1
            self.moved_points = moved_points
            changed = True
        if scene.corner_normals is not old.corner_normals:
            self.corner_normals.assign(_f32(scene.corner_normals, 3))
            changed = True
        if scene.corner_colors is not old.corner_colors and not np.array_equal(scene.corner_colors, old.corner_colors):
            self.corner_colors = wp.array(_corner_colors(scene), dtype=wp.vec3, device=self.device)
            changed = elsewhere = True
        self.scene = scene
        lights_changed = scene.lights != old.lights
        if lights_changed:
            self._upload_lights(scene)
        materials_changed = scene.materials is not old.materials and scene.materials != old.materials
        if materials_changed:
            self._upload_materials(scene)
        if _texture_source(scene) != self._texture_source:
            self._upload_textures(scene)
            changed = elsewhere = True
        if not same_dome(dome_source(scene), self._dome_source):
            self._upload_dome(scene)
            changed = elsewhere = True
        if changed or lights_changed or materials_changed:
            self.content_version += 1
            local = box is not None and not (elsewhere or lights_changed or materials_changed)
            self.moved = MovedGeometry(since, *box) if local else None
        # The indirect estimate follows the lights and the materials; points that only move
        # leave it as it was (an animation barely changes the surface area).
        if self.indirect and (lights_changed or materials_changed):
            self._indirect_e = self._indirect_estimate(scene)
            self.ambient.indirect = wp.vec3(*self._indirect_e)
        # The features follow the used materials (the triangles' are unchanged), whether
        # there are lights, whether there is a dome and the estimate: re-analysed only
        # when those change.
        if (
            materials_changed
            or bool(scene.lights) != bool(old.lights)
            or (scene.environment is None) != (old.environment is None)
            or (self.indirect and lights_changed)
        ):
            self.features = self._features(scene)
        self.gpu = self._make_struct()
