"""Small USD authoring helpers over pxr, shared by ``scripts/make_scenes.py`` and
``warp-hybrid convert``.

Everything is authored the way the shared scenes are (see ``../shared/scenes/README.md``):
one default prim ``/World`` with ``Geom``, ``Looks``, ``Lights`` and ``Cameras`` scopes,
meshes with per-vertex (``vertex`` interpolation) ``normals`` and ``primvars:st`` and
``subdivisionScheme = none``, ``UsdPreviewSurface`` materials whose extra properties sit
in the material's ``customData`` under ``sa:``, lights and cameras placed with one
``xformOp:transform``.

Output is deterministic: points, normals and uvs are stored as float32, and every double
(matrices, light and camera parameters) is rounded to 9 decimals, so regenerating a file
on another CPU gives the same bytes even where libm differs in the last bit.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdShade, Vt

from gaze.atomic import replace_atomically
from gaze.errors import GazeError

from ...errors import SceneError
from ..usd.pxr_text import tf_message

USD_EXTENSIONS = (".usda", ".usdc")
SCOPES = ("Geom", "Looks", "Lights", "Cameras")
_DECIMALS = 9

Vec3 = Sequence[float]


def _clean(values: np.ndarray | Sequence[float], dtype: type = np.float64) -> np.ndarray:
    """``values`` as ``dtype`` with doubles rounded to 9 decimals and -0 turned into +0."""
    a = np.asarray(values, dtype=np.float64)
    if dtype == np.float64:
        a = np.round(a, _DECIMALS)
    return np.asarray(a, dtype=dtype) + dtype(0.0)


def _floats(values: Sequence[float]) -> tuple[float, ...]:
    """A short tuple of Python floats, rounded like every other double we write."""
    return tuple(float(v) for v in _clean(values))


def _unit(v: np.ndarray) -> np.ndarray:
    """``v`` scaled to unit length (``v`` must not be zero)."""
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ValueError("zero-length direction")
    return v / n


def frame_matrix(origin: Vec3, z_axis: Vec3, up: Vec3 = (0.0, 1.0, 0.0)) -> Gf.Matrix4d:
    """The rigid transform whose local +Z is ``z_axis``, local +Y as close to ``up`` as
    possible, placed at ``origin`` (USD row-vector layout: rows are x, y, z, translation).

    When ``z_axis`` is parallel to ``up`` the up hint falls back to -Z (or +Y).
    """
    z = _unit(np.asarray(z_axis, dtype=np.float64))
    hint = np.asarray(up, dtype=np.float64)
    if np.linalg.norm(np.cross(hint, z)) < 1e-9 * max(1.0, float(np.linalg.norm(hint))):
        hint = np.array([0.0, 0.0, -1.0]) if abs(z[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = _unit(np.cross(hint, z))
    y = np.cross(z, x)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3], m[3, :3] = x, y, z, np.asarray(origin, dtype=np.float64)
    return Gf.Matrix4d(*_clean(m).ravel().tolist())


def look_at_matrix(eye: Vec3, target: Vec3, up: Vec3 = (0.0, 1.0, 0.0)) -> Gf.Matrix4d:
    """Camera-to-world transform of a camera at ``eye`` looking at ``target`` (the camera
    looks down its local -Z with +Y up)."""
    e = np.asarray(eye, dtype=np.float64)
    return frame_matrix(e, e - np.asarray(target, dtype=np.float64), up)


def new_stage(meters_per_unit: float = 1.0, up_axis: str = "Y", doc: str | None = None) -> Usd.Stage:
    """An in-memory stage with ``/World`` (default prim) and its Geom/Looks/Lights/Cameras
    scopes, ``upAxis`` and ``metersPerUnit`` set."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if up_axis.upper() == "Y" else UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, float(meters_per_unit))
    if doc:
        stage.GetRootLayer().documentation = doc
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    for name in SCOPES:
        UsdGeom.Scope.Define(stage, f"/World/{name}")
    return stage


def set_time_range(stage: Usd.Stage, start: float, end: float, fps: float = 24.0) -> None:
    """Author the stage's start/end time codes and time codes (and frames) per second."""
    stage.SetStartTimeCode(float(start))
    stage.SetEndTimeCode(float(end))
    stage.SetTimeCodesPerSecond(float(fps))
    stage.SetFramesPerSecond(float(fps))


def check_usd_path(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path when it ends in .usda or .usdc, else a SceneError naming it."""
    p = Path(path)
    if p.suffix.lower() not in USD_EXTENSIONS:
        raise SceneError(str(p), f"unsupported output extension {p.suffix!r}: use .usda or .usdc")
    return p


def save_stage(stage: Usd.Stage, path: str | os.PathLike[str]) -> None:
    """Write the stage's root layer to ``path`` (.usda text or .usdc crate, by extension)
    atomically (``gaze.atomic``: a temporary file in the same folder, then a rename).
    Nothing is left behind (and an existing file is untouched) when writing fails."""
    dst = check_usd_path(path)

    def export(tmp: Path) -> None:
        if not stage.GetRootLayer().Export(str(tmp)):
            raise SceneError(str(dst), "USD could not write the layer")

    try:
        replace_atomically(dst, export, temp_suffix=dst.suffix.lower())
    except GazeError as exc:
        raise SceneError(str(dst), f"cannot write file: {exc.problem}") from exc
    except Tf.ErrorException as exc:
        raise SceneError(str(dst), f"cannot write file: {tf_message(exc)}") from exc


def define_mesh(
    stage: Usd.Stage,
    path: str,
    points: np.ndarray,
    indices: np.ndarray,
    normals: np.ndarray | None = None,
    uvs: np.ndarray | None = None,
    *,
    face_vertex_counts: Sequence[int] | None = None,
    hole_indices: Sequence[int] = (),
    double_sided: bool = False,
    left_handed: bool = False,
    display_color: np.ndarray | None = None,
) -> UsdGeom.Mesh:
    """A ``UsdGeom.Mesh`` at ``path`` from numpy arrays.

    ``indices`` is (T, 3) triangles, unless ``face_vertex_counts`` is given, then it is
    the flat faceVertexIndices of those polygons.  ``normals`` (N, 3) and ``uvs`` (N, 2)
    are per vertex (``vertex`` interpolation); ``display_color`` is (N, 3) per vertex or
    (F, 3) per face (``uniform``).  ``subdivisionScheme`` is ``none``; ``extent`` is
    computed from the points.
    """
    pts = _clean(points, np.float32).reshape(-1, 3)
    flat = np.asarray(indices, dtype=np.int64).reshape(-1)
    counts = np.full(len(flat) // 3, 3) if face_vertex_counts is None else np.asarray(face_vertex_counts, np.int64)
    if face_vertex_counts is None and len(flat) % 3:
        raise ValueError(f"{path}: triangle indices must come in threes")
    if int(counts.sum()) != len(flat) or (len(flat) and (flat.min() < 0 or flat.max() >= len(pts))):
        raise ValueError(f"{path}: face counts/indices do not match {len(pts)} points")
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts.astype(np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(flat.astype(np.int32)))
    if len(hole_indices):
        mesh.CreateHoleIndicesAttr(Vt.IntArray([int(h) for h in hole_indices]))
    mesh.CreateExtentAttr(UsdGeom.Mesh.ComputeExtent(mesh.GetPointsAttr().Get()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded if left_handed else UsdGeom.Tokens.rightHanded)
    mesh.CreateDoubleSidedAttr(bool(double_sided))
    if normals is not None:
        nrm = _clean(normals, np.float32).reshape(-1, 3)
        if len(nrm) != len(pts):
            raise ValueError(f"{path}: {len(nrm)} normals for {len(pts)} points")
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(nrm))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    if uvs is not None:
        st = _clean(uvs, np.float32).reshape(-1, 2)
        if len(st) != len(pts):
            raise ValueError(f"{path}: {len(st)} uvs for {len(pts)} points")
        pv = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        pv.Set(Vt.Vec2fArray.FromNumpy(st))
    if display_color is not None:
        col = _clean(display_color, np.float32).reshape(-1, 3)
        if len(col) not in (len(pts), len(counts)):
            raise ValueError(f"{path}: {len(col)} display colours for {len(pts)} points / {len(counts)} faces")
        interp = UsdGeom.Tokens.vertex if len(col) == len(pts) else UsdGeom.Tokens.uniform
        mesh.CreateDisplayColorPrimvar(interp).Set(Vt.Vec3fArray.FromNumpy(col))
    return mesh


def set_custom_data(prim: Usd.Prim, values: Mapping[str, object]) -> None:
    """Store ``values`` in ``prim``'s customData under the ``sa`` dictionary (the shared
    scenes' convention): floats as double, bools, 3-tuples as double3, 2-tuples of ints
    as int2, strings."""
    for key, value in sorted(values.items()):
        if isinstance(value, bool | str):
            v: object = value
        elif isinstance(value, int | float):
            v = float(_clean([value])[0])
        elif len(value) == 2 and all(isinstance(c, int | np.integer) for c in value):  # type: ignore[arg-type]
            v = Gf.Vec2i(*(int(c) for c in value))  # type: ignore[union-attr]
        elif len(value) == 3:  # type: ignore[arg-type]
            v = Gf.Vec3d(*_floats(value))  # type: ignore[arg-type]
        else:
            raise ValueError(f"unsupported customData value for {key!r}: {value!r}")
        prim.SetCustomDataByKey(f"sa:{key}", v)


def define_material(
    stage: Usd.Stage,
    path: str,
    *,
    diffuse: Vec3 = (0.18, 0.18, 0.18),
    roughness: float = 0.5,
    metallic: float = 0.0,
    opacity: float = 1.0,
    ior: float | None = 1.5,
    emissive: Vec3 | None = None,
    opacity_threshold: float | None = None,
    diffuse_texture: str | None = None,
    texture_scale: Sequence[float] | None = None,
    texture_color_space: str = "sRGB",
    texture_wrap: str = "repeat",
    opacity_from_texture: bool = False,
    opacity_mode: str | None = None,
    custom_data: Mapping[str, object] | None = None,
) -> UsdShade.Material:
    """A ``UsdShade.Material`` with one ``UsdPreviewSurface`` ("PreviewSurface").

    ``diffuse_texture`` (an asset path, written as given) adds a ``UsdUVTexture``
    ("diffuseTexture", ``texture_scale`` = RGBA multiplier) read through a
    ``UsdPrimvarReader_float2`` ("stReader", varname ``st``) driving diffuseColor, and
    opacity too when ``opacity_from_texture``.  ``ior`` None authors none (with opacity
    below 1: alpha blending, not glass); ``opacity_mode`` authors ``opacityMode``
    ("transparent" or "presence").  ``custom_data`` goes under ``sa:``.
    """
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    inputs = {
        "diffuseColor": (Sdf.ValueTypeNames.Color3f, Gf.Vec3f(*_floats(diffuse))),
        "roughness": (Sdf.ValueTypeNames.Float, float(roughness)),
        "metallic": (Sdf.ValueTypeNames.Float, float(metallic)),
        "opacity": (Sdf.ValueTypeNames.Float, float(opacity)),
    }
    if ior is not None:
        inputs["ior"] = (Sdf.ValueTypeNames.Float, float(ior))
    if opacity_mode is not None:
        inputs["opacityMode"] = (Sdf.ValueTypeNames.Token, opacity_mode)
    if emissive is not None:
        inputs["emissiveColor"] = (Sdf.ValueTypeNames.Color3f, Gf.Vec3f(*_floats(emissive)))
    if opacity_threshold is not None:
        inputs["opacityThreshold"] = (Sdf.ValueTypeNames.Float, float(opacity_threshold))
    for name, (type_name, value) in inputs.items():
        shader.CreateInput(name, type_name).Set(value)
    if diffuse_texture is not None:
        reader = UsdShade.Shader.Define(stage, f"{path}/stReader")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        tex = UsdShade.Shader.Define(stage, f"{path}/diffuseTexture")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(diffuse_texture))
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(texture_color_space)
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(texture_wrap)
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(texture_wrap)
        if texture_scale is not None:
            tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*_floats(texture_scale)))
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader.ConnectableAPI(), "result", UsdShade.AttributeType.Output, Sdf.ValueTypeNames.Float2
        )
        shader.GetInput("diffuseColor").ConnectToSource(
            tex.ConnectableAPI(), "rgb", UsdShade.AttributeType.Output, Sdf.ValueTypeNames.Float3
        )
        if opacity_from_texture:
            shader.GetInput("opacity").ConnectToSource(
                tex.ConnectableAPI(), "a", UsdShade.AttributeType.Output, Sdf.ValueTypeNames.Float
            )
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    if custom_data:
        set_custom_data(material.GetPrim(), custom_data)
    return material


def bind_material(prim: Usd.Prim | UsdGeom.Imageable, material: UsdShade.Material) -> None:
    """Bind ``material`` to ``prim`` (a prim or a schema object; applies MaterialBindingAPI)."""
    UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(material)


def _place(xformable: UsdGeom.Xformable, matrix: Gf.Matrix4d) -> None:
    """Give ``xformable`` a single ``xformOp:transform`` holding ``matrix``."""
    xformable.AddTransformOp().Set(matrix)


def _light_common(
    light: UsdLux.BoundableLightBase | UsdLux.NonboundableLightBase, intensity: float, color: Vec3
) -> None:
    """Author intensity and colour on a UsdLux light."""
    light.CreateIntensityAttr(float(intensity))
    light.CreateColorAttr(Gf.Vec3f(*_floats(color)))


def define_distant_light(
    stage: Usd.Stage,
    path: str,
    direction: Vec3,
    intensity: float = 1.0,
    color: Vec3 = (1.0, 1.0, 1.0),
    angle_deg: float = 0.53,
) -> UsdLux.DistantLight:
    """A DistantLight whose photons travel along ``direction`` (its local -Z)."""
    light = UsdLux.DistantLight.Define(stage, path)
    _light_common(light, intensity, color)
    light.CreateAngleAttr(float(angle_deg))
    _place(light, frame_matrix((0.0, 0.0, 0.0), -np.asarray(direction, dtype=np.float64)))
    return light


def define_sphere_light(
    stage: Usd.Stage, path: str, position: Vec3, radius: float, intensity: float = 1.0, color: Vec3 = (1.0, 1.0, 1.0)
) -> UsdLux.SphereLight:
    """A SphereLight of ``radius`` centred at ``position``."""
    light = UsdLux.SphereLight.Define(stage, path)
    _light_common(light, intensity, color)
    light.CreateRadiusAttr(float(radius))
    _place(light, frame_matrix(position, (0.0, 0.0, 1.0)))
    return light


def define_rect_light(
    stage: Usd.Stage,
    path: str,
    center: Vec3,
    direction: Vec3,
    width: float,
    height: float,
    intensity: float = 1.0,
    color: Vec3 = (1.0, 1.0, 1.0),
    up: Vec3 = (0.0, 1.0, 0.0),
) -> UsdLux.RectLight:
    """A RectLight centred at ``center`` emitting along ``direction`` (its local -Z);
    ``width`` runs along local X, ``height`` along local Y (Y as close to ``up`` as the
    direction allows)."""
    light = UsdLux.RectLight.Define(stage, path)
    _light_common(light, intensity, color)
    light.CreateWidthAttr(float(width))
    light.CreateHeightAttr(float(height))
    _place(light, frame_matrix(center, -np.asarray(direction, dtype=np.float64), up))
    return light


def define_dome_light(
    stage: Usd.Stage, path: str, intensity: float = 1.0, color: Vec3 = (1.0, 1.0, 1.0), texture_file: str | None = None
) -> UsdLux.DomeLight:
    """A DomeLight: a constant colour, or a lat-long texture (asset path written as
    given) times the colour.  Default orientation: +Y pole, OpenEXR lat-long mapping."""
    light = UsdLux.DomeLight.Define(stage, path)
    _light_common(light, intensity, color)
    if texture_file is not None:
        light.CreateTextureFileAttr(Sdf.AssetPath(texture_file))
        light.CreateTextureFormatAttr(UsdLux.Tokens.latlong)
    return light


def define_camera(
    stage: Usd.Stage,
    path: str,
    eye: Vec3,
    target: Vec3,
    hfov_deg: float,
    resolution: tuple[int, int] = (640, 480),
    up: Vec3 = (0.0, 1.0, 0.0),
    clipping: tuple[float, float] = (0.01, 1.0e4),
    focal_length: float = 50.0,
) -> UsdGeom.Camera:
    """A perspective ``UsdGeom.Camera`` at ``eye`` looking at ``target``.

    Horizontal aperture fit: ``horizontalAperture = 2 * focalLength * tan(hfov / 2)``;
    ``verticalAperture`` follows the intended ``resolution`` (stored in customData
    ``sa:resolution`` as in the shared scenes).
    """
    cam = UsdGeom.Camera.Define(stage, path)
    h_ap = 2.0 * focal_length * np.tan(np.radians(hfov_deg) / 2.0)
    width, height = resolution
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.CreateFocalLengthAttr(float(focal_length))
    cam.CreateHorizontalApertureAttr(float(_clean([h_ap])[0]))
    cam.CreateVerticalApertureAttr(float(_clean([h_ap * height / width])[0]))
    cam.CreateClippingRangeAttr(Gf.Vec2f(*_floats(clipping)))
    _place(cam, look_at_matrix(eye, target, up))
    set_custom_data(cam.GetPrim(), {"resolution": (int(width), int(height))})
    return cam


def animate_look_at(
    camera: UsdGeom.Camera, keys: Iterable[tuple[float, Vec3, Vec3]], up: Vec3 = (0.0, 1.0, 0.0)
) -> None:
    """Replace ``camera``'s static transform by time samples ``(time, eye, target)``."""
    attr = camera.GetOrderedXformOps()[0].GetAttr()
    attr.Clear()
    for time, eye, target in keys:
        attr.Set(look_at_matrix(eye, target, up), Usd.TimeCode(float(time)))
