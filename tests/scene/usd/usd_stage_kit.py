"""Small helpers for the USD loader tests: build tiny stages with pxr in tmp_path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

from warp_hybrid.lighting.indirect import triangle_areas  # noqa: F401  (re-exported for the USD tests)
from warp_hybrid.scene.model import Scene
from warp_hybrid.scene.usd.loader import load_scene


def new_stage(
    tmp_path: Path, name: str = "scene.usda", up_axis: str = "Y", meters_per_unit: float = 1.0
) -> tuple[Usd.Stage, Path]:
    """A new stage file in ``tmp_path`` with a /World default prim."""
    path = tmp_path / name
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up_axis)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    return stage, path


def add_mesh(
    stage: Usd.Stage,
    path: str,
    points,
    counts,
    indices,
    subdivision: str = "none",
    **attrs,
) -> UsdGeom.Mesh:
    """A UsdGeom.Mesh with the given polygons (``subdivisionScheme`` none by default)."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([Gf.Vec3f(*map(float, p)) for p in points])
    mesh.CreateFaceVertexCountsAttr([int(c) for c in counts])
    mesh.CreateFaceVertexIndicesAttr([int(i) for i in indices])
    if subdivision is not None:
        mesh.CreateSubdivisionSchemeAttr(subdivision)
    for name, value in attrs.items():
        getattr(mesh, f"Create{name}Attr")(value)
    return mesh


def unit_quad(stage: Usd.Stage, path: str, z: float = 0.0, size: float = 1.0) -> UsdGeom.Mesh:
    """A counter-clockwise quad in the XY plane (facing +Z) from (0,0) to (size,size)."""
    s = size
    return add_mesh(stage, path, [(0, 0, z), (s, 0, z), (s, s, z), (0, s, z)], [4], [0, 1, 2, 3])


def static_and_moving_quads(tmp_path: Path) -> tuple[Usd.Stage, Path]:
    """A stage with the quads /World/Static and /World/Mover/Q; /World/Mover is translated
    from (0, 0, 0) at time 0 to (0, 4, 0) at time 8."""
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Static")
    op = UsdGeom.Xform.Define(stage, "/World/Mover").AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 0.0)
    op.Set(Gf.Vec3d(0, 4, 0), 8.0)
    unit_quad(stage, "/World/Mover/Q")
    return stage, path


def preview_material(stage: Usd.Stage, path: str, **inputs) -> tuple[UsdShade.Material, UsdShade.Shader]:
    """A material with a UsdPreviewSurface; ``inputs`` are constant values
    (tuples of 3 become color3f, ints int, floats float)."""
    mat = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    for name, value in inputs.items():
        if isinstance(value, tuple):
            shader.CreateInput(name, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*value))
        elif isinstance(value, int) and not isinstance(value, bool):
            shader.CreateInput(name, Sdf.ValueTypeNames.Int).Set(value)
        else:
            shader.CreateInput(name, Sdf.ValueTypeNames.Float).Set(float(value))
    return mat, shader


def bind(prim: Usd.Prim | UsdGeom.Imageable, material: UsdShade.Material) -> None:
    """Apply MaterialBindingAPI and bind ``material`` to ``prim``."""
    p = prim.GetPrim() if hasattr(prim, "GetPrim") else prim
    UsdShade.MaterialBindingAPI.Apply(p).Bind(material)


def save_and_load(stage: Usd.Stage, path: Path, time: float | None = None) -> Scene:
    """Save the stage and load it with the loader under test."""
    stage.GetRootLayer().Save()
    return load_scene(path, time)


def triangle_normals(scene: Scene) -> np.ndarray:
    """Unit geometric normals (T, 3) of the scene's triangles (counter-clockwise)."""
    p = scene.points.astype(np.float64)[scene.indices]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def set_st(mesh: UsdGeom.Mesh, uvs, interpolation: str = "vertex") -> None:
    """Author ``primvars:st`` (texCoord2f[]) on ``mesh`` with this interpolation."""
    st = mesh.GetPrim().CreateAttribute("primvars:st", Sdf.ValueTypeNames.TexCoord2fArray)
    st.Set(Vt.Vec2fArray([Gf.Vec2f(float(u), float(v)) for u, v in uvs]))
    st.SetMetadata("interpolation", interpolation)


def st_reader(stage: Usd.Stage, path: str, varname: str = "st") -> UsdShade.Output:
    """A ``UsdPrimvarReader_float2`` of ``varname`` at ``path``; returns its result output."""
    reader = UsdShade.Shader.Define(stage, path)
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    return reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)


def uv_texture(
    stage: Usd.Stage, path: str, file: str, st: UsdShade.Output | None, output: str = "rgb", **inputs
) -> UsdShade.Output:
    """A ``UsdUVTexture`` at ``path`` reading ``file`` (its ``st`` from ``st`` when given);
    ``scale``/``bias`` are 4-tuples, other ``inputs`` tokens.  Returns its ``output``."""
    tex = UsdShade.Shader.Define(stage, path)
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    if st is not None:
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st)
    for key, value in inputs.items():
        if key in ("scale", "bias"):
            tex.CreateInput(key, Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*map(float, value)))
        else:
            tex.CreateInput(key, Sdf.ValueTypeNames.Token).Set(value)
    kinds = {"rgb": Sdf.ValueTypeNames.Float3, "rgba": Sdf.ValueTypeNames.Float4}
    return tex.CreateOutput(output, kinds.get(output, Sdf.ValueTypeNames.Float))


def mesh_world_points(scene: Scene, prim_path: str) -> np.ndarray:
    """World positions (N, 3) float64 of the points of the mesh ``prim_path`` in ``scene``."""
    (r,) = [m for m in scene.meshes if m.prim_path == prim_path]
    return scene.points[r.first_point : r.first_point + r.point_count].astype(np.float64) + scene.origin


def draw_mode_model(
    stage: Usd.Stage,
    path: str,
    mode: str | None,
    apply: bool | None = None,
    kind: str | None = None,
    color: tuple[float, float, float] | None = None,
) -> UsdGeom.Xform:
    """An Xform at ``path`` with GeomModelAPI applied; ``mode`` (None: unauthored, i.e.
    inherited), ``apply`` (model:applyDrawMode; None: unauthored), ``kind`` and
    ``color`` (model:drawModeColor) are authored when given."""
    xform = UsdGeom.Xform.Define(stage, path)
    model = UsdGeom.ModelAPI.Apply(xform.GetPrim())
    if mode is not None:
        model.CreateModelDrawModeAttr(mode)
    if apply is not None:
        model.CreateModelApplyDrawModeAttr(apply)
    if kind is not None:
        Usd.ModelAPI(xform.GetPrim()).SetKind(kind)
    if color is not None:
        model.CreateModelDrawModeColorAttr(Gf.Vec3f(*color))
    return xform


def materialx_surface(stage: Usd.Stage, material: UsdShade.Material, name: str = "Std") -> UsdShade.Shader:
    """An ``ND_standard_surface_surfaceshader`` under ``material`` connected to its
    ``outputs:mtlx:surface``."""
    shader = UsdShade.Shader.Define(stage, material.GetPath().AppendChild(name))
    shader.CreateIdAttr("ND_standard_surface_surfaceshader")
    shader.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.8, 0.1, 0.1))
    out = shader.CreateOutput("out", Sdf.ValueTypeNames.Token)
    material.CreateSurfaceOutput("mtlx").ConnectToSource(out)
    return shader
