"""USD stage -> host ``Scene``: traversal, instancing, caching across time codes.

``load_scene(path, time)`` is the one-shot entry point; ``UsdSceneSource`` keeps the
stage open for animation.  Its first ``scene_at(t)`` is a full evaluation: it traverses
the stage, reads every mesh (static meshes' local and world data are cached) and
records what may vary over time.  Later calls take the fast path (``_update``) and
re-evaluate only that, reusing the previous scene's arrays for everything else:

* meshes whose transform (any ancestor) or points/topology/normals are time-varying,
  and PointInstancers whose instance attributes, own or prototype transforms vary:
  their points, normals (and, where they changed, indices, uvs, materials) are written
  at their ``MeshRange`` offsets into copies of the previous arrays; an array none of
  them changed is the previous scene's array itself, so a stage where nothing is
  animated returns the very same arrays at every time (``DeviceScene.update`` skips
  the copy by identity).  The arrays are read-only: scenes of one source share them.
* lights (all re-read when any light's attributes or transform vary) and cameras
  (each re-read when its attributes or transform vary);
* visibility: the time-varying ``visibility`` attributes are read at the new time and
  compared with the last traversal's values.

When a visibility value, an instancer's instance lists or a mesh's point or triangle
count differs (what appears, disappears or changes topology), the call falls back to a
full evaluation, so its result and errors are those of the full path (``DeviceScene.update``
then refuses the changed topology as before).  Materials, displayColor and the uvs of
static meshes are read once (at the first time evaluated), as before.  Successive frames
have the same topology (``DeviceScene.update`` refits instead of rebuilding) as long as
visibility, topology and instance counts are not themselves animated.

Traversal (``Usd.TraverseInstanceProxies``, so instanceable prims come through as
instance proxies and share one triangulation per prototype mesh):

* ``UsdGeom.Mesh`` prims and the implicit Cube, Sphere, Cone, Cylinder, Capsule and
  Plane (tessellated by ``implicit``) that are visible at the time code and whose
  purpose is ``default`` or ``render`` (guide and proxy are skipped); a mesh whose
  topology is malformed is skipped with a warning naming it (``strict`` refuses the
  stage instead);
* ``UsdGeom.PointInstancer``: one batch per prototype mesh with all its instance
  transforms (``ComputeInstanceTransformsAtTime``; inactive/invisible ids masked);
* models whose ``model:drawMode`` applies (``draw_mode``): drawn as the box of their
  bounds in their drawModeColor (bounds, cards) or not at all (origin) instead of their
  subtree, in PointInstancer prototypes too;
* UsdLux lights (see ``lights``) and every ``UsdGeom.Camera`` (visible or not);
* anything else that draws (other gprims such as Points, BasisCurves, NURBS,
  volumes; light filters; mesh lights) is reported once per prim and skipped, never
  dropped silently.

Meshes that author a ``subdivisionScheme`` are refined (``subdivision``;
``subdivision_levels``: by default chosen per mesh from its size on the ``screen``
through the default camera, ``subdivision_level.AUTO``; unauthored, the USD fallback catmullClark, they stay
polygon meshes with one warning).  Meshes bound to a Skeleton (``SkelBindingAPI``) are
drawn with pxr's skinned points (``skel``); when the animation (or anything else the
skinning reads) is time-sampled they vary over time like animated points.

A stage with no light and no dome is lit as usdview lights it (``default_light``:
a headlight along the default camera's view and a dim dome), with one warning.
Colour primvars a material follows per corner (displayColor that varies over an
unbound mesh, a UsdPrimvarReader on diffuseColor) fill ``Scene.corner_colors``
(``primvars``).

``MeshRange.prim_path`` is the mesh prim (an instance proxy path for instanceable
prims, ``MESH@INSTANCER[i]`` for PointInstancer instance ``i``).  A stage without
cameras gets one framing camera (``camera.framing_camera``), placed at the first
time code evaluated and kept still afterwards.  The stage is treated as read-only
while the source is open.

World positions are computed in float64 and stored relative to the source's local
origin (``scene.local_frame.choose_origin``: from the default camera at the first time
evaluated, then fixed), so points, cameras and lights keep float32 precision wherever
the stage sits; ``Scene.origin`` holds it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdLux, UsdShade

from ...errors import SceneError
from ..local_frame import choose_origin, local_camera, local_light, local_points
from ..model import Camera, Environment, Light, Material, MeshRange, Scene
from .camera import FRAMING_CAMERA_NAME, framing_camera, read_camera
from .default_light import DEFAULT_LIGHT_WARNING, default_dome, headlight, uses_default_lighting
from .draw_mode import StandIn, stand_in, stand_in_mesh
from .gprims import empty_mesh, is_drawn, read_gprim
from .lights import read_lights
from .materials import DEFAULT_UV_SET, MaterialLibrary, bound_material
from .meshes import LocalMesh, MalformedMeshError, WorldMesh, corner_uvs, to_world
from .primvars import DISPLAY_COLOR, PrimvarInput, corner_colors, read_display_color
from .skel import NOT_APPLIED, Skinner, Skinning
from .stage import StageInfo, open_stage, read_stage_info, report_composition_errors
from .stage_metadata import check_stage_metadata
from .subdivision import DEFAULT_LEVELS
from .subdivision_level import AUTO, DEFAULT_SCREEN, LevelChooser, Levels, check_levels, screen_chooser
from .textures import ImageLibrary
from .triangle_order import reorder_part
from .validate import Diagnostics, check_extent, validate_scene

_SKIPPED_PURPOSES = (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)
_INSTANCER_ATTRS = (
    "positions",
    "orientations",
    "orientationsf",
    "scales",
    "protoIndices",
    "velocities",
    "angularVelocities",
    "invisibleIds",
)
_GEOMETRY = ("points", "indices", "corner_normals", "corner_uvs", "triangle_material", "corner_colors")


@dataclass
class _Item:
    """One mesh to draw, once or as a batch of instances (``matrices`` (K, 4, 4));
    ``skin``: its skinning, for a mesh bound to a Skeleton; ``stand_in``: for a model
    drawn as the box of its bounds (``draw_mode``), ``prim`` being the model."""

    key: str
    prim: Usd.Prim
    source: str
    matrices: np.ndarray
    animated: bool
    names: list[str]
    skin: Skinning | None = None
    stand_in: StandIn | None = None


@dataclass
class _Part:
    """An item in world space with its per-triangle materials."""

    world: WorldMesh
    triangle_material: np.ndarray
    names: list[str]
    animated: bool


@dataclass
class _Instancer:
    """A PointInstancer's items ``items[start:stop]``; ``rerun``: its instance or
    prototype transforms may vary, so later times evaluate it again."""

    prim: Usd.Prim
    xanim: bool
    start: int
    stop: int
    rerun: bool


@dataclass
class _Traversal:
    """What one traversal found, and what of it may vary over time: ``visibility``
    holds the time-varying visibility attributes (by path) with the value read;
    ``cameras_vary[i]`` tells whether ``cameras[i]`` may vary."""

    items: list[_Item]
    lights: list[Usd.Prim]
    cameras: list[Usd.Prim]
    instancers: list[_Instancer]
    visibility: dict[Sdf.Path, tuple[Usd.Attribute, object]]
    lights_vary: bool
    cameras_vary: list[bool]


@dataclass
class _Frame:
    """The last scene returned, with the traversal and the per-item parts it was made of
    (``parts[i]`` lies at ``first_point[i]`` / ``first_triangle[i]``).  ``dynamic``: the
    items whose part may vary; ``retransform``: the mesh items (not instancer items)
    whose transform may vary."""

    scene: Scene
    trav: _Traversal
    parts: list[_Part]
    first_point: list[int]
    first_triangle: list[int]
    dynamic: list[int]
    retransform: list[int]


class _Patch:
    """Copy-on-write of a scene's geometry arrays: ``write`` puts a part's data at its
    offsets, copying an array the first time one of its slices changes; an array whose
    slices all hold the same bits stays the previous scene's array itself."""

    def __init__(self, scene: Scene) -> None:
        self.arrays = {name: getattr(scene, name) for name in _GEOMETRY}
        self.origin = scene.origin
        self.finite = True
        self._copied: set[str] = set()

    def write(self, part: _Part, first_point: int, first_triangle: int) -> None:
        w = part.world
        self._put("points", first_point, local_points(w.points, self.origin))
        self._put("indices", first_triangle, w.tri_points + first_point)
        self._put("corner_normals", first_triangle, w.corner_normals)
        self._put("corner_uvs", first_triangle, w.corner_uvs)
        self._put("triangle_material", first_triangle, part.triangle_material)
        if w.corner_colors is not None and self.arrays["corner_colors"].size:
            self._put("corner_colors", first_triangle, w.corner_colors)
        self.finite = self.finite and all(np.isfinite(a).all() for a in (w.points, w.corner_normals, w.corner_uvs))

    def _put(self, name: str, first: int, values: np.ndarray) -> None:
        arr = self.arrays[name]
        values = np.ascontiguousarray(values, dtype=arr.dtype)
        view = arr[first : first + len(values)]
        if np.array_equal(view.view(np.int32), values.view(np.int32)):  # every dtype is 4 bytes; -0.0 != 0.0
            return
        if name not in self._copied:
            arr = self.arrays[name] = arr.copy()
            self._copied.add(name)
            view = arr[first : first + len(values)]
        view[...] = values


def _freeze(scene: Scene) -> None:
    """Make the geometry arrays read-only: later scenes of the source share them."""
    for name in _GEOMETRY:
        getattr(scene, name).flags.writeable = False


def _same_list(previous: list, current: list) -> list:
    """``previous`` itself while it holds the very objects of ``current``, else a copy of ``current``."""
    if len(previous) == len(current) and all(a is b for a, b in zip(previous, current)):
        return previous
    return list(current)


def _attributes_vary(prim: Usd.Prim) -> bool:
    return any(a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes())


def _source_key(prim: Usd.Prim) -> str:
    """Cache key for a mesh's local data: its prototype prim for instance proxies."""
    return str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())


def _has_texture(m: Material) -> bool:
    return any(t >= 0 for t in m.texture_slots())


def _matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


class UsdSceneSource:
    """An open USD stage that produces ``Scene`` snapshots at time codes."""

    def __init__(
        self,
        path: str | os.PathLike,
        stage: Usd.Stage | None = None,
        strict: bool = False,
        subdivision_levels: Levels = AUTO,
        screen: tuple[int, int] = DEFAULT_SCREEN,
    ) -> None:
        """Open ``path`` (or wrap an already opened ``stage``, e.g. one converted from
        another format in memory; ``path`` then names it in messages).  ``strict``: a
        malformed mesh raises ``SceneError`` instead of being skipped with a warning.
        ``subdivision_levels``: how often meshes that author a subdivision scheme are
        refined (0: drawn as their control cage; ``AUTO``: per mesh, from its size on a
        ``screen`` of (width, height) pixels, ``subdivision_level``)."""
        self.subdivision_levels = check_levels(subdivision_levels)
        if not (len(screen) == 2 and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in screen)):
            raise ValueError(f"screen must be (width, height) in whole pixels > 0, not {screen!r}")
        self.screen = (int(screen[0]), int(screen[1]))
        self.path = os.fspath(path)
        self.strict = strict
        self.diagnostics = Diagnostics(self.path)
        if stage is None:
            stage = open_stage(self.path, self.diagnostics)
        else:
            report_composition_errors(stage, self.diagnostics)
        self.stage = stage
        self.info: StageInfo = check_stage_metadata(read_stage_info(stage), stage, self.path, self.diagnostics)
        self.images = ImageLibrary(self.diagnostics)
        self._skinner = Skinner(self.diagnostics)
        self._skipped: set[str] = set()  # source keys of malformed meshes, drawn as nothing
        self._headlit = False  # default lighting (no lights on the stage) is in use
        self._materials: MaterialLibrary | None = None
        self._local: dict[str, LocalMesh] = {}
        self._parts: dict[str, _Part] = {}
        self._framing: Camera | None = None
        self._level_camera: Camera | None = None  # the camera AUTO subdivision levels are chosen for
        self._levels: dict[str, int] = {}  # AUTO: the level chosen for each mesh source, kept
        self._origin: np.ndarray | None = None  # the local frame, chosen at the first evaluation
        self._frame: _Frame | None = None  # the last evaluation, which later times update
        # False while no used layer holds time samples and no prim uses value clips:
        # then nothing can vary over time and the per-attribute queries are skipped.
        self._may_animate = any(len(layer.ListAllTimeSamples()) for layer in stage.GetUsedLayers())

    @property
    def time_range(self) -> tuple[float, float] | None:
        """(startTimeCode, endTimeCode) when the stage authors a range, else None."""
        return self.info.time_range

    @property
    def warnings(self) -> list[str]:
        """Every warning reported so far (each once)."""
        return list(self.diagnostics.messages)

    def scene_at(self, time: float | None = None) -> Scene:
        """The scene at ``time`` (default: the start of the time range, or 0).

        After the first call only what may vary over time is evaluated again (see the
        module docs); the result is the same as a full evaluation's."""
        t = self.info.default_time if time is None else float(time)
        if not math.isfinite(t):
            raise SceneError(self.path, f"time code {time!r} is not a finite number")
        if self._frame is not None:
            scene = self._update(self._frame, t)
            if scene is not None:
                return scene
        return self._evaluate(t)

    def _evaluate(self, t: float) -> Scene:
        """The full evaluation: traverse, read every item, assemble; record the frame."""
        if self._materials is None:
            self._materials = MaterialLibrary(self.images, self.diagnostics, t)
        xcache = UsdGeom.XformCache(Usd.TimeCode(t))
        try:  # textures decode on worker threads meanwhile; always collect them
            trav = self._traverse(t, xcache)
            cameras = [read_camera(p, t, self.diagnostics) for p in trav.cameras]
            if self._level_camera is None and self.subdivision_levels == AUTO:
                self._level_camera = cameras[0] if cameras else self._bounds_camera(t)
            parts = [self._part(item, t) for item in trav.items]
            lights, environment = read_lights(trav.lights, t, xcache, self.images, self.diagnostics)
        finally:
            self.images.finish()
        if not cameras:
            if self._framing is None:  # framed once, at the first time evaluated, then kept still
                self.diagnostics.warn(
                    f"the stage has no UsdGeom.Camera; using {FRAMING_CAMERA_NAME} that frames the scene bounds"
                )
                self._framing = framing_camera(*_world_bounds(parts), self.info.up_axis)
            cameras = [self._framing]
        if self._origin is None:  # one local frame for every time of the source
            self._origin = choose_origin(cameras[0])
        scene = self._assemble(parts, t, self._origin)
        scene.lights = [local_light(light, self._origin) for light in lights]
        scene.environment = environment
        scene.cameras = [local_camera(c, self._origin) for c in cameras]
        scene.lights, scene.environment = self._lighting(scene.lights, scene.environment, scene.cameras[0])
        scene.images = list(self.images.images)
        scene.textures = list(self.images.textures)
        scene.materials = list(self._materials.materials)
        self._warn_if_empty(trav, parts, scene)
        scene.warnings = self.warnings
        validate_scene(scene)
        _freeze(scene)
        self._frame = self._record(scene, trav, parts)
        return scene

    def _lighting(self, lights: list[Light], environment: Environment | None, camera: Camera) -> tuple:
        """(lights, environment): the stage's own, or when it has none the default
        lighting aimed along ``camera`` (``default_light``; warned once)."""
        self._headlit = uses_default_lighting(lights, environment)
        if not self._headlit:
            return lights, environment
        self.diagnostics.warn(DEFAULT_LIGHT_WARNING)
        return [headlight(camera)], default_dome()

    def _warn_if_empty(self, trav: _Traversal, parts: list[_Part], scene: Scene) -> None:
        """Warn (once per source) about meshes without faces (malformed ones were warned
        about when skipped) and a scene with nothing to draw."""
        diag = self.diagnostics
        for item, part in zip(trav.items, parts):
            if not len(part.world.tri_points) and item.source not in self._skipped:
                diag.warn("the mesh has no faces: nothing of it is drawn", str(item.prim.GetPath()))
        if scene.triangle_count == 0:
            diag.warn("nothing to see: the stage has no mesh faces to draw; the image is only the background")

    @staticmethod
    def _record(scene: Scene, trav: _Traversal, parts: list[_Part]) -> _Frame:
        sizes = np.array([(len(p.world.points), len(p.world.tri_points)) for p in parts], dtype=np.int64)
        sizes = sizes.reshape(-1, 2)
        first = np.cumsum(sizes, axis=0) - sizes
        instanced = np.zeros(len(parts), dtype=bool)
        for group in trav.instancers:
            instanced[group.start : group.stop] = True
        return _Frame(
            scene=scene,
            trav=trav,
            parts=parts,
            first_point=first[:, 0].tolist(),
            first_triangle=first[:, 1].tolist(),
            dynamic=[i for i, p in enumerate(parts) if p.animated],
            retransform=[i for i, item in enumerate(trav.items) if item.animated and not instanced[i]],
        )

    def _update(self, frame: _Frame, t: float) -> Scene | None:
        """The fast path: ``frame`` at time ``t``, evaluating only what may vary; None
        when something appeared, disappeared or changed topology (then the caller runs
        the full evaluation, which reports or handles it as always)."""
        trav, prev = frame.trav, frame.scene
        tc = Usd.TimeCode(t)
        if any(attr.Get(tc) != value for attr, value in trav.visibility.values()):
            return None
        xcache = UsdGeom.XformCache(tc)
        items = list(trav.items)
        for group in trav.instancers:
            if group.rerun:
                new, _rerun = self._instancer_items(group.prim, tc, xcache, group.xanim)
                if [(i.key, i.names) for i in new] != [(i.key, i.names) for i in items[group.start : group.stop]]:
                    return None
                items[group.start : group.stop] = new
        for i in frame.retransform:
            items[i] = replace(items[i], matrices=_matrix(xcache.GetLocalToWorldTransform(items[i].prim))[None])
        patch = _Patch(prev)
        parts = list(frame.parts)
        cameras = prev.cameras
        lights, environment = prev.lights, prev.environment
        try:
            for i in frame.dynamic:
                part, old = self._part(items[i], t), frame.parts[i]
                if part.world.points.shape != old.world.points.shape or (
                    part.world.tri_points.shape != old.world.tri_points.shape
                ):
                    return None
                patch.write(part, frame.first_point[i], frame.first_triangle[i])
                parts[i] = part
            if trav.lights_vary:
                lights, environment = read_lights(trav.lights, t, xcache, self.images, self.diagnostics)
                lights = [local_light(light, prev.origin) for light in lights]
            if any(trav.cameras_vary):
                cameras = [
                    local_camera(read_camera(prim, t, self.diagnostics), prev.origin) if vary else old
                    for prim, vary, old in zip(trav.cameras, trav.cameras_vary, prev.cameras)
                ]
            if trav.lights_vary or (self._headlit and any(trav.cameras_vary)):  # re-aim the headlight
                stage_lights = (lights, environment) if trav.lights_vary else ([], None)
                lights, environment = self._lighting(*stage_lights, cameras[0])
        finally:
            self.images.finish()
        scene = replace(  # what did not change is the previous scene's own object (arrays, lists)
            prev,
            **patch.arrays,
            lights=lights,
            environment=environment,
            cameras=cameras,
            time=t,
            images=_same_list(prev.images, self.images.images),
            textures=_same_list(prev.textures, self.images.textures),
            materials=_same_list(prev.materials, self._materials.materials),
            warnings=self.warnings,
        )
        if not patch.finite:
            validate_scene(scene)  # raises naming the prim, as the full evaluation does
        elif frame.dynamic or trav.lights_vary or any(trav.cameras_vary):
            check_extent(scene)  # what moved may have left the representable range
        _freeze(scene)
        frame.scene, frame.parts, frame.trav = scene, parts, replace(trav, items=items)
        return scene

    # -- traversal -----------------------------------------------------------------------

    def _traverse(self, time: float, xcache: UsdGeom.XformCache) -> _Traversal:
        tc = Usd.TimeCode(time)
        diag = self.diagnostics
        items: list[_Item] = []
        lights: list[Usd.Prim] = []
        cameras: list[Usd.Prim] = []
        instancers: list[_Instancer] = []
        visibility: dict[Sdf.Path, tuple[Usd.Attribute, object]] = {}
        lights_vary = False
        cameras_vary: list[bool] = []
        state: dict = {}
        unauthored_subdiv: list[str] = []
        it = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        next(it)  # the pseudo-root
        for prim in it:
            path = prim.GetPath()
            hidden, pinfo, xanim = state.get(path.GetParentPath(), (False, None, False))
            if prim.IsA(UsdShade.Material) or prim.IsA(UsdShade.Shader) or prim.IsA(UsdShade.NodeGraph):
                it.PruneChildren()
                continue
            if not self._may_animate and prim.HasAuthoredMetadata("clips"):
                self._may_animate = True
            if prim.IsA(UsdGeom.Imageable):
                img = UsdGeom.Imageable(prim)
                if self._watch_visibility(img, tc, visibility) == UsdGeom.Tokens.invisible:
                    hidden = True
                pinfo = img.ComputePurposeInfo(pinfo) if pinfo is not None else img.ComputePurposeInfo()
            if self._may_animate and prim.IsA(UsdGeom.Xformable):
                xf = UsdGeom.Xformable(prim)
                xanim = (xanim and not xf.GetResetXformStack()) or xf.TransformMightBeTimeVarying()
            state[path] = (hidden, pinfo, xanim)
            if prim.IsA(UsdGeom.Camera):
                cameras.append(prim)
                cameras_vary.append(self._may_animate and (xanim or _attributes_vary(prim)))
                continue
            if hidden or (pinfo is not None and pinfo.purpose in _SKIPPED_PURPOSES):
                continue
            name = str(path)
            model = stand_in(prim, tc, diag)
            if model is not None:  # its subtree is not drawn (as if hidden: cameras still count)
                state[path] = (True, pinfo, xanim)
                if model.draws_box:
                    m = _matrix(xcache.GetLocalToWorldTransform(prim))[None]
                    items.append(_Item(name, prim, name, m, xanim, [name], stand_in=model))
                continue
            if is_drawn(prim):
                self._check_mesh_features(prim, unauthored_subdiv)
                m = _matrix(xcache.GetLocalToWorldTransform(prim))[None]
                skin = None
                if prim.IsA(UsdGeom.Mesh) and "SkelBindingAPI" in prim.GetAppliedSchemas():
                    skin = self._skinner.binding(prim, self._may_animate)
                source = name if skin is not None else _source_key(prim)  # skinned instances differ
                items.append(_Item(name, prim, source, m, xanim, [name], skin))
            elif prim.IsA(UsdGeom.PointInstancer):
                batch, rerun = self._instancer_items(prim, tc, xcache, xanim, visibility)
                instancers.append(_Instancer(prim, xanim, len(items), len(items) + len(batch), rerun))
                items.extend(batch)
                it.PruneChildren()
            elif prim.IsA(UsdLux.LightFilter):
                diag.warn("light filters are not supported; ignored", name)
            elif prim.HasAPI(UsdLux.LightAPI):
                lights.append(prim)
                lights_vary = lights_vary or (self._may_animate and (xanim or _attributes_vary(prim)))
            elif prim.IsA(UsdGeom.Gprim):
                diag.warn(f"{prim.GetTypeName()} prims are not supported (only UsdGeom.Mesh); skipped", name)
        if unauthored_subdiv:
            diag.warn(
                f"{len(unauthored_subdiv)} meshes do not author subdivisionScheme (USD fallback: catmullClark); "
                f"rendered as polygon meshes (first: {unauthored_subdiv[0]})",
                key="unauthored-subdivision-scheme",
            )
        return _Traversal(items, lights, cameras, instancers, visibility, lights_vary, cameras_vary)

    def _watch_visibility(
        self, img: UsdGeom.Imageable, tc: Usd.TimeCode, watch: dict[Sdf.Path, tuple[Usd.Attribute, object]]
    ) -> object:
        """``img``'s own visibility at ``tc``, kept in ``watch`` when it may vary."""
        attr = img.GetVisibilityAttr()
        value = attr.Get(tc)
        if self._may_animate and attr.ValueMightBeTimeVarying():
            watch[attr.GetPath()] = (attr, value)
        return value

    def _check_mesh_features(self, prim: Usd.Prim, unauthored_subdiv: list[str], in_prototype: bool = False) -> None:
        """Note a mesh that leaves subdivisionScheme unauthored; warn about what is not
        applied to ``prim``: mesh lights, skinning of implicit prims and of prototypes."""
        diag = self.diagnostics
        name = str(prim.GetPath())
        is_mesh = prim.IsA(UsdGeom.Mesh)
        if is_mesh and not UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().HasAuthoredValue():
            unauthored_subdiv.append(name)
        applied = prim.GetAppliedSchemas()
        if "MeshLightAPI" in applied:
            diag.warn("MeshLightAPI emission is not supported; the mesh renders with its material only", name)
        if "SkelBindingAPI" in applied and (in_prototype or not is_mesh):
            where = "in a PointInstancer prototype" if in_prototype else f"to a {prim.GetTypeName()} (only to meshes)"
            diag.warn(f"{NOT_APPLIED} {where}; rendered in its rest pose", name)

    def _instancer_items(
        self,
        prim: Usd.Prim,
        tc: Usd.TimeCode,
        xcache: UsdGeom.XformCache,
        xanim: bool,
        watch: dict[Sdf.Path, tuple[Usd.Attribute, object]] | None = None,
    ) -> tuple[list[_Item], bool]:
        """The instancer's items, and whether they may vary over time (its instance
        attributes, its own or its prototypes' transforms).  The time-varying visibility
        of the prototypes and their ancestors goes to ``watch``."""
        diag = self.diagnostics
        name = str(prim.GetPath())
        pi = UsdGeom.PointInstancer(prim)
        animated = xanim or (
            self._may_animate
            and any(prim.GetAttribute(a).ValueMightBeTimeVarying() for a in _INSTANCER_ATTRS if prim.GetAttribute(a))
        )
        xforms = np.asarray(
            pi.ComputeInstanceTransformsAtTime(
                tc, tc, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
            ),
            dtype=np.float64,
        ).reshape(-1, 4, 4)
        proto_idx = np.asarray(pi.GetProtoIndicesAttr().Get(tc) or [], dtype=np.int64)
        if len(xforms) != len(proto_idx):
            if len(proto_idx):
                diag.warn(
                    "instance attributes disagree in length (positions/orientations/scales vs protoIndices); skipped",
                    name,
                )
            return [], animated
        mask = pi.ComputeMaskAtTime(tc)
        active = np.asarray(mask, dtype=bool) if len(mask) else np.ones(len(proto_idx), dtype=bool)
        targets = pi.GetPrototypesRel().GetTargets()
        bad = (proto_idx < 0) | (proto_idx >= len(targets))
        if bad.any():
            diag.warn(
                f"{int(bad.sum())} protoIndices reach outside the {len(targets)} prototypes; "
                "those instances are skipped",
                name,
            )
            active &= ~bad
        world = _matrix(xcache.GetLocalToWorldTransform(prim))
        items = []
        for j, target in enumerate(targets):
            sel = np.flatnonzero(active & (proto_idx == j))
            proto = self.stage.GetPrimAtPath(target)
            if not sel.size or not proto:
                continue
            for mesh, rel, rel_animated, model in self._prototype_meshes(proto, tc, xcache, watch):
                matrices = rel[None] @ xforms[sel] @ world[None]
                mesh_name = str(mesh.GetPath())
                items.append(
                    _Item(
                        key=f"{name}[{j}]{mesh_name}",
                        prim=mesh,
                        source=_source_key(mesh) if model is None else mesh_name,
                        matrices=matrices,
                        animated=animated or rel_animated,
                        names=[f"{mesh_name}@{name}[{i}]" for i in sel],
                        stand_in=model,
                    )
                )
        return items, animated or any(item.animated for item in items)

    def _prototype_meshes(
        self,
        proto: Usd.Prim,
        tc: Usd.TimeCode,
        xcache: UsdGeom.XformCache,
        watch: dict[Sdf.Path, tuple[Usd.Attribute, object]] | None = None,
    ):
        """(mesh prim, transform relative to the prototype root, animated, stand-in) for
        each drawable mesh of a PointInstancer prototype and each model in it drawn as a
        box (``draw_mode``; its stand-in, else None); animated covers the prototype
        root's own transform, which the instance transforms include."""
        diag = self.diagnostics
        out = []
        if watch is not None:  # the ancestors' visibility is part of ComputeVisibility
            p = proto.GetParent()
            while p:
                if p.IsA(UsdGeom.Imageable):
                    self._watch_visibility(UsdGeom.Imageable(p), tc, watch)
                p = p.GetParent()
        it = iter(Usd.PrimRange(proto, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in it:
            if not prim.IsA(UsdGeom.Imageable):
                continue
            img = UsdGeom.Imageable(prim)
            if watch is not None:
                self._watch_visibility(img, tc, watch)
            if img.ComputeVisibility(tc) == UsdGeom.Tokens.invisible or img.ComputePurpose() in _SKIPPED_PURPOSES:
                it.PruneChildren()
                continue
            name = str(prim.GetPath())
            model = stand_in(prim, tc, diag)
            if model is not None:
                it.PruneChildren()
                if model.draws_box:
                    out.append((prim, *self._relative_transform(prim, proto, xcache), model))
            elif prim.IsA(UsdGeom.PointInstancer):
                diag.warn("nested PointInstancers are not supported; skipped", name)
                it.PruneChildren()
            elif is_drawn(prim):
                self._check_mesh_features(prim, [], in_prototype=True)
                out.append((prim, *self._relative_transform(prim, proto, xcache), None))
            elif prim.IsA(UsdGeom.Gprim):
                diag.warn(f"{prim.GetTypeName()} prims are not supported (only UsdGeom.Mesh); skipped", name)
        return out

    def _relative_transform(
        self, prim: Usd.Prim, proto: Usd.Prim, xcache: UsdGeom.XformCache
    ) -> tuple[np.ndarray, bool]:
        """(transform of ``prim`` relative to the prototype root ``proto``, whether it may
        vary: the transform of ``prim`` or of an ancestor up to ``proto`` included)."""
        rel, _resets = xcache.ComputeRelativeTransform(prim, proto)
        animated = False
        p = prim
        while self._may_animate and p:
            animated = animated or UsdGeom.Xformable(p).TransformMightBeTimeVarying()
            p = None if p == proto else p.GetParent()
        return _matrix(rel), animated

    # -- per-item data ----------------------------------------------------------------------------

    def _part(self, item: _Item, time: float) -> _Part:
        cached = self._parts.get(item.key)
        if cached is not None:
            return cached
        local = self._local.get(item.source)
        if local is None:
            local = self._read_local(item, time)
            if not local.time_varying:
                self._local[item.source] = local
        if not np.isfinite(item.matrices).all():
            raise SceneError(self.path, "its local-to-world transform is not finite", item.names[0])
        tri_material, varname, textured, colour_source = self._triangle_materials(item.prim, local, item.stand_in)
        uvs = corner_uvs(local, item.prim, varname, time, self.diagnostics, textured)
        colours = None
        if colour_source is not None:
            colours = corner_colors(local, item.prim, colour_source, time, self.diagnostics)
        world = to_world(local, uvs, item.matrices, colours)
        animated = local.time_varying or item.animated
        tri_material = np.tile(tri_material, item.matrices.shape[0])
        if animated:  # (kept in the authored order: later times patch it in place)
            return _Part(world, tri_material, item.names, animated)
        part = self._parts[item.key] = _Part(*reorder_part(world, tri_material), item.names, animated)
        return part

    def _read_local(self, item: _Item, time: float) -> LocalMesh:
        """The item's prim in its local space (skinned and subdivided as it asks); a
        malformed mesh is skipped with a warning naming it (an empty mesh), or raises
        when the source is strict.  A model's stand-in is the box of its bounds."""
        if item.stand_in is not None:
            return stand_in_mesh(item.prim, time, self._may_animate)
        try:
            skin = item.skin
            points = None if skin is None else self._skinner.local_points(skin, time)
            varies = skin is not None and skin.varies
            levels = self._mesh_levels(item)
            return read_gprim(item.prim, time, self.path, self.diagnostics, self._may_animate, points, varies, levels)
        except MalformedMeshError as exc:
            if self.strict:
                raise
            self._skipped.add(item.source)
            self.diagnostics.warn(f"malformed mesh skipped, nothing of it is drawn: {exc.problem}", exc.prim)
            return empty_mesh(item.prim)

    def _mesh_levels(self, item: _Item) -> int | LevelChooser:
        """The subdivision levels of ``item``'s mesh: the fixed number, or under ``AUTO``
        the level chosen for it once (a chooser that remembers it, asked only where the
        mesh authors a scheme)."""
        if self.subdivision_levels != AUTO:
            return self.subdivision_levels
        if item.source in self._levels:
            return self._levels[item.source]
        if self._level_camera is None:
            return DEFAULT_LEVELS
        choose = screen_chooser(item.matrices, self._level_camera, self.screen[0])

        def remember(points: np.ndarray, counts: np.ndarray, indices: np.ndarray) -> int:
            return self._levels.setdefault(item.source, choose(points, counts, indices))

        return remember

    def _bounds_camera(self, t: float) -> Camera | None:
        """The framing camera of the stage's bounds as pxr computes them (the cameras
        are chosen before any mesh is read), None for a stage with empty bounds."""
        purposes = [UsdGeom.Tokens.default_, UsdGeom.Tokens.render, UsdGeom.Tokens.proxy]
        cache = UsdGeom.BBoxCache(Usd.TimeCode(t), purposes, useExtentsHint=True)
        box = cache.ComputeWorldBound(self.stage.GetPseudoRoot()).ComputeAlignedRange()
        if box.IsEmpty():
            return None
        return framing_camera(np.array(box.GetMin()), np.array(box.GetMax()), self.info.up_axis)

    def _mesh_material(self, prim: Usd.Prim, material: UsdShade.Material | None, double_sided: bool) -> int:
        lib = self._materials
        if material is not None:
            return lib.index(material, double_sided)
        colour, varies = read_display_color(prim, lib.time)
        if varies:  # followed per corner (``primvars``)
            return lib.vertex_colored(DISPLAY_COLOR, double_sided)
        if colour is not None:
            return lib.display_color(str(prim.GetPath()), colour, double_sided)
        return lib.default(double_sided)

    def _triangle_materials(
        self, prim: Usd.Prim, local: LocalMesh, model: StandIn | None
    ) -> tuple[np.ndarray, str, bool, PrimvarInput | None]:
        """Per-triangle material indices (GeomSubset bindings honoured), the uv
        primvar their textures read, whether any of them is textured, and the colour
        primvar their vertex-coloured materials follow (None when none does).  The box
        of a ``model`` drawn as its stand-in takes its drawModeColor as a displayColor."""
        lib = self._materials
        ds = local.double_sided
        if model is not None:
            index = lib.display_color(str(prim.GetPath()), model.color, ds)
            return np.full(local.triangle_count, index, dtype=np.int32), DEFAULT_UV_SET, False, None
        mesh_index = self._mesh_material(prim, bound_material(prim), ds)
        used = [mesh_index]
        subsets = UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets()
        if not subsets:
            tri = np.full(local.triangle_count, mesh_index, dtype=np.int32)
        else:
            face = np.full(local.face_count, mesh_index, dtype=np.int32)
            for subset in subsets:
                if subset.GetElementTypeAttr().Get() != UsdGeom.Tokens.face:
                    self.diagnostics.warn("material subsets must have elementType face; ignored", str(subset.GetPath()))
                    continue
                idx = np.asarray(subset.GetIndicesAttr().Get(lib.time) or [], dtype=np.int64)
                idx = idx[(idx >= 0) & (idx < local.face_count)]
                mat = bound_material(subset.GetPrim())
                sub_index = lib.index(mat, ds) if mat is not None else mesh_index
                face[idx] = sub_index
                used.append(sub_index)
            tri = face[local.tri_face]
        textured = [i for i in used if _has_texture(lib.materials[i])]
        varname = lib.uv_primvar[textured[0]] if textured else lib.uv_primvar[mesh_index]
        coloured = [lib.materials[i] for i in dict.fromkeys(used) if lib.materials[i].is_vertex_colored]
        source = PrimvarInput(coloured[0].diffuse_primvar, coloured[0].diffuse) if coloured else None
        if len({m.diffuse_primvar for m in coloured}) > 1:
            self.diagnostics.warn(
                f"its materials follow several colour primvars; only {coloured[0].diffuse_primvar!r} is read",
                str(prim.GetPath()),
            )
        return tri, varname, bool(textured), source

    def _assemble(self, parts: list[_Part], time: float, origin: np.ndarray) -> Scene:
        """The parts' flat arrays, points in the frame of ``origin`` (``scene.local_frame``)."""
        n_points = sum(len(p.world.points) for p in parts)
        n_tris = sum(len(p.world.tri_points) for p in parts)
        points = np.empty((n_points, 3), dtype=np.float32)
        indices = np.empty((n_tris, 3), dtype=np.int32)
        normals = np.empty((n_tris, 3, 3), dtype=np.float32)
        uvs = np.empty((n_tris, 3, 2), dtype=np.float32)
        materials = np.empty((n_tris,), dtype=np.int32)
        coloured = any(p.world.corner_colors is not None for p in parts)
        colours = np.zeros((n_tris if coloured else 0, 3, 3), dtype=np.float32)
        ranges: list[MeshRange] = []
        pb = tb = 0
        for p in parts:
            w = p.world
            n, t = len(w.points), len(w.tri_points)
            points[pb : pb + n] = local_points(w.points, origin)
            indices[tb : tb + t] = w.tri_points + pb
            normals[tb : tb + t] = w.corner_normals
            uvs[tb : tb + t] = w.corner_uvs
            materials[tb : tb + t] = p.triangle_material
            if w.corner_colors is not None:
                colours[tb : tb + t] = w.corner_colors
            pn, tn = n // w.instances, t // w.instances
            for k, name in enumerate(p.names):
                ranges.append(MeshRange(name, tb + k * tn, tn, pb + k * pn, pn, p.animated))
            pb += n
            tb += t
        info = self.info
        return Scene(
            path=self.path,
            points=points,
            indices=indices,
            corner_normals=normals,
            corner_uvs=uvs,
            triangle_material=materials,
            materials=[],
            meshes=ranges,
            time=time,
            time_range=info.time_range,
            time_codes_per_second=info.time_codes_per_second,
            meters_per_unit=info.meters_per_unit,
            up_axis=info.up_axis,
            origin=origin,
            corner_colors=colours,
        )


def _world_bounds(parts: list[_Part]) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned world bounds (min, max) of the parts' points (zeros when empty)."""
    pts = [p.world.points for p in parts if len(p.world.points)]
    if not pts:
        return np.zeros(3), np.zeros(3)
    lo = np.min([np.min(p, axis=0) for p in pts], axis=0).astype(np.float64)
    hi = np.max([np.max(p, axis=0) for p in pts], axis=0).astype(np.float64)
    return lo, hi


def load_scene(
    path: str | os.PathLike,
    time: float | None = None,
    strict: bool = False,
    subdivision_levels: Levels = AUTO,
    screen: tuple[int, int] = DEFAULT_SCREEN,
) -> Scene:
    """Load the USD file ``path`` as a ``Scene`` at ``time`` (default: the start of its
    time range, or 0).  Raises ``SceneError`` naming the file (and prim) for bad input;
    ``strict``: a malformed mesh too (else it is skipped with a warning).
    ``subdivision_levels`` and ``screen``: see ``UsdSceneSource``."""
    return UsdSceneSource(path, strict=strict, subdivision_levels=subdivision_levels, screen=screen).scene_at(time)
