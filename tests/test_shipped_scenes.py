"""The project's own scenes (scenes/*.usda, made by scripts/make_scenes.py), checked
with pxr alone: structure, materials, lights, cameras, the geometry each hard case
promises, and that the script regenerates them byte for byte."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import numpy as np
import pytest
from pxr import Usd, UsdGeom, UsdLux, UsdShade

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
NAMES = ("cornell_glass", "metal_env", "hard_cases", "textured_animated")
GENERATED = [f"{n}.usda" for n in NAMES] + ["textures/sky.hdr", "textures/orientation.png"]


def _open(name: str) -> Usd.Stage:
    stage = Usd.Stage.Open(str(SCENES / f"{name}.usda"))
    assert stage is not None
    return stage


def _meshes(stage: Usd.Stage) -> dict[str, UsdGeom.Mesh]:
    return {str(p.GetPath()): UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)}


def _world_points(mesh: UsdGeom.Mesh, time: float = 0.0) -> np.ndarray:
    m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(time)))
    p = np.array(mesh.GetPointsAttr().Get(), dtype=np.float64)
    return p @ m[:3, :3] + m[3, :3]


def _triangles(mesh: UsdGeom.Mesh) -> np.ndarray:
    """Fan-triangulated (T, 3) indices without hole faces, counter-clockwise = front."""
    counts = mesh.GetFaceVertexCountsAttr().Get()
    idx = np.array(mesh.GetFaceVertexIndicesAttr().Get())
    holes = set(mesh.GetHoleIndicesAttr().Get() or [])
    tris, start = [], 0
    for face, n in enumerate(counts):
        if face not in holes:
            tris += [(idx[start], idx[start + k], idx[start + k + 1]) for k in range(1, n - 1)]
        start += n
    tris = np.array(tris)
    return tris[:, [0, 2, 1]] if mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded else tris


def _geometric_normals(mesh: UsdGeom.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Unnormalised world-space face normals (T, 3) and the triangles (T, 3)."""
    p, t = _world_points(mesh), _triangles(mesh)
    return np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]), t


def _is_closed(points: np.ndarray, tris: np.ndarray) -> bool:
    """Every edge (vertices welded by position) is shared by exactly two triangles."""
    scale = max(float(np.ptp(points, axis=0).max()), 1e-30)
    _, weld = np.unique(np.round(points / scale, 6), axis=0, return_inverse=True)
    t = weld.reshape(-1)[tris]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


def _surface(stage: Usd.Stage, path: str) -> UsdShade.Shader:
    return UsdShade.Shader(stage.GetPrimAtPath(f"{path}/PreviewSurface"))


def _bound_surface(stage: Usd.Stage, mesh: UsdGeom.Mesh) -> UsdShade.Shader:
    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    assert material, f"{mesh.GetPath()} has no material"
    return _surface(stage, str(material.GetPath()))


def _camera(stage: Usd.Stage, path: str = "/World/Cameras/Main", time: float = 0.0):
    cam = UsdGeom.Camera(stage.GetPrimAtPath(path))
    assert cam, f"no camera {path}"
    return cam.GetCamera(Usd.TimeCode(time))


def _project(gf_cam, points: np.ndarray) -> np.ndarray:
    """NDC (x, y) in [-1, 1] (horizontal aperture fit) and view depth, (N, 3)."""
    m = np.array(gf_cam.transform)
    local = (np.asarray(points, dtype=np.float64) - m[3, :3]) @ m[:3, :3].T
    depth = -local[:, 2]
    tx = gf_cam.horizontalAperture / (2.0 * gf_cam.focalLength)
    ty = gf_cam.verticalAperture / (2.0 * gf_cam.focalLength)
    return np.stack([local[:, 0] / depth / tx, local[:, 1] / depth / ty, depth], axis=1)


def _lights(stage: Usd.Stage) -> dict[str, str]:
    return {str(p.GetPath()): p.GetTypeName() for p in stage.Traverse() if p.HasAPI(UsdLux.LightAPI)}


@pytest.mark.parametrize("name", NAMES)
def test_scene_structure(name: str) -> None:
    path = SCENES / f"{name}.usda"
    assert path.stat().st_size < 1_000_000
    stage = _open(name)
    assert stage.GetDefaultPrim().GetPath() == "/World"
    assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    cam = _camera(stage)
    width, height = stage.GetPrimAtPath("/World/Cameras/Main").GetCustomData()["sa"]["resolution"]
    assert cam.horizontalAperture / cam.verticalAperture == pytest.approx(width / height, rel=1e-6)
    assert _lights(stage)
    meshes = _meshes(stage)
    assert meshes
    for mesh in meshes.values():
        pts = _world_points(mesh)
        idx = np.array(mesh.GetFaceVertexIndicesAttr().Get())
        assert np.isfinite(pts).all() and idx.min() >= 0 and idx.max() < len(pts)
        assert sum(mesh.GetFaceVertexCountsAttr().Get()) == len(idx)
        assert mesh.GetSubdivisionSchemeAttr().Get() == UsdGeom.Tokens.none
        _bound_surface(stage, mesh)
        normals = mesh.GetNormalsAttr().Get()
        if normals is None:
            continue
        assert mesh.GetNormalsInterpolation() == UsdGeom.Tokens.vertex and len(normals) == len(pts)
        # authored normals agree with the winding of every non-degenerate triangle
        fn, tris = _geometric_normals(mesh)
        m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(0.0)))[:3, :3]
        vn = (np.array(normals, dtype=np.float64) @ np.linalg.inv(m).T)[tris].sum(axis=1)
        ok = np.einsum("ij,ij->i", fn, vn) > 0
        assert ok[np.linalg.norm(fn, axis=1) > 1e-12].all(), f"{mesh.GetPath()}: normals disagree with winding"


@pytest.mark.parametrize("name", NAMES)
def test_closed_meshes_face_out_and_open_ones_face_a_camera(name: str) -> None:
    """Single-sided geometry is oriented so a rasteriser with back-face culling sees it."""
    stage = _open(name)
    eyes = [
        np.array(UsdGeom.Camera(p).GetCamera(Usd.TimeCode(0.0)).transform.ExtractTranslation())
        for p in stage.Traverse()
        if p.IsA(UsdGeom.Camera)
    ]
    for mesh in _meshes(stage).values():
        if mesh.GetDoubleSidedAttr().Get():
            continue
        fn, tris = _geometric_normals(mesh)
        pts = _world_points(mesh)
        if _is_closed(pts, tris):
            centroids = pts[tris].mean(axis=1)
            volume = np.einsum("ij,ij->", centroids - pts.mean(axis=0), fn) / 6.0
            assert volume > 0, f"{mesh.GetPath()} faces inwards"
        else:
            centre = pts.mean(axis=0)
            facing = [np.all((fn @ (eye - centre)) > 0) for eye in eyes]
            assert any(facing), f"{mesh.GetPath()} faces away from every camera"


def test_cornell_glass_materials_lights_and_coloured_shadow() -> None:
    stage = _open("cornell_glass")
    glass = _surface(stage, "/World/Looks/Glass")
    assert glass.GetInput("opacity").Get() == 0.0 and glass.GetInput("ior").Get() == pytest.approx(1.5)
    sa = stage.GetPrimAtPath("/World/Looks/Glass").GetCustomData()["sa"]
    assert sa["transmission"] == 1.0 and sa["thinWalled"] is False
    mirror = _surface(stage, "/World/Looks/Mirror")
    assert mirror.GetInput("metallic").Get() == 1.0 and mirror.GetInput("roughness").Get() == 0.0
    assert min(mirror.GetInput("diffuseColor").Get()) >= 0.9
    pane = _surface(stage, "/World/Looks/RedPane")
    red = np.array(pane.GetInput("diffuseColor").Get())
    assert 0.0 < pane.GetInput("opacity").Get() < 1.0 and red[0] > 5 * red[1:].max()
    assert stage.GetPrimAtPath("/World/Looks/RedPane").GetCustomData()["sa"]["thinWalled"] is True
    meshes = _meshes(stage)
    assert _bound_surface(stage, meshes["/World/Geom/GlassSphere"]).GetPath() == glass.GetPath()
    assert _bound_surface(stage, meshes["/World/Geom/MirrorPanel"]).GetPath() == mirror.GetPath()
    emissive = _bound_surface(stage, meshes["/World/Geom/LightPatch"]).GetInput("emissiveColor").Get()
    assert min(emissive) > 1.0
    assert sorted(_lights(stage).values()) == ["RectLight", "SphereLight"]

    # the box is about one unit, every wall faces its centre
    lo = np.min([_world_points(m).min(axis=0) for m in meshes.values()], axis=0)
    hi = np.max([_world_points(m).max(axis=0) for m in meshes.values()], axis=0)
    np.testing.assert_allclose(hi - lo, (1.0, 1.0, 1.0), atol=1e-6)
    for wall in ("Floor", "Ceiling", "Back", "Left", "Right"):
        fn, _ = _geometric_normals(meshes[f"/World/Geom/{wall}"])
        centre = _world_points(meshes[f"/World/Geom/{wall}"]).mean(axis=0)
        assert np.all(fn @ ((0.0, 0.5, 0.0) - centre) > 0), wall

    # the pane's shadow from each light lands on the floor, inside the box and in view
    pane_pts = _world_points(meshes["/World/Geom/RedPane"])
    cam = _camera(stage)
    for light_path in _lights(stage):
        light = np.array(UsdGeom.Xformable(stage.GetPrimAtPath(light_path)).ComputeLocalToWorldTransform(0.0))[3, :3]
        t = light[1] / (light[1] - pane_pts[:, 1])
        shadow = light + t[:, None] * (pane_pts - light)
        assert np.all(np.abs(shadow[:, 0]) < 0.5) and np.all(np.abs(shadow[:, 2]) < 0.5), light_path
        assert np.ptp(shadow[:, 2]) > 0.05, f"{light_path}: shadow has no extent on the floor"
        assert np.all(np.abs(_project(cam, shadow)[:, :2]) < 1.0), light_path


def _refract(d: np.ndarray, n: np.ndarray, eta: float) -> np.ndarray:
    """Snell refraction of unit ``d`` through a surface with unit normal ``n`` facing ``-d``."""
    cos_i = -float(d @ n)
    k = 1.0 - eta * eta * (1.0 - cos_i * cos_i)
    return eta * d + (eta * cos_i - np.sqrt(k)) * n


def test_cornell_glass_prism_shows_total_internal_reflection() -> None:
    """A camera ray entering the prism's front face, in view above the glass ball, meets
    the hypotenuse beyond the critical angle of IOR 1.5."""
    stage = _open("cornell_glass")
    meshes = _meshes(stage)
    prism = meshes["/World/Geom/GlassPrism"]
    assert _bound_surface(stage, prism).GetPath() == _surface(stage, "/World/Looks/Glass").GetPath()
    fn, tris = _geometric_normals(prism)
    pts = _world_points(prism)
    unit = fn / np.linalg.norm(fn, axis=1, keepdims=True)
    eye = np.array(_camera(stage).transform.ExtractTranslation())
    front = int(np.argmax(unit[:, 2]))
    hyp = int(np.argmax(unit @ np.array([1.0, 0.0, -1.0])))
    facing = np.unique(tris[np.all(np.isclose(unit, unit[front]), axis=1)])
    target = pts[facing].mean(axis=0) + (0.0, 0.17, 0.0)  # centre of the front face, raised
    assert target[1] < pts[:, 1].max()
    d = (target - eye) / np.linalg.norm(target - eye)
    ball = _world_points(meshes["/World/Geom/GlassSphere"])
    centre, radius = ball.mean(axis=0), np.ptp(ball[:, 1]) / 2.0
    assert np.linalg.norm(np.cross(centre - eye, d)) > radius  # not hidden behind the ball
    inside = _refract(d, unit[front], 1.0 / 1.5)
    incidence = np.degrees(np.arccos(inside @ unit[hyp]))
    assert incidence > np.degrees(np.arcsin(1.0 / 1.5)) + 1.0


def _latlong_direction(row: int, col: int, height: int, width: int) -> np.ndarray:
    """OpenEXR / UsdLux lat-long: left column longitude +pi, longitude 0 = +Z,
    longitude pi/2 = +X, top row latitude +pi/2 = +Y."""
    lon = np.pi - 2.0 * np.pi * (col + 0.5) / width
    lat = np.pi / 2.0 - np.pi * (row + 0.5) / height
    return np.array([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)])


def test_metal_env_dome_sun_and_roughness_sweep() -> None:
    stage = _open("metal_env")
    lights = _lights(stage)
    assert sorted(lights.values()) == ["DistantLight", "DomeLight"]
    dome = UsdLux.DomeLight(stage.GetPrimAtPath(next(p for p, t in lights.items() if t == "DomeLight")))
    assert dome.GetTextureFormatAttr().Get() == "latlong"
    hdr = cv2.imread(dome.GetTextureFileAttr().Get().resolvedPath, cv2.IMREAD_UNCHANGED)
    assert hdr.dtype == np.float32 and hdr.shape == (128, 256, 3)
    lum = hdr.sum(axis=2)
    rows, cols = np.nonzero(lum > 0.5 * lum.max())
    sun_dir = np.mean([_latlong_direction(r, c, *lum.shape) for r, c in zip(rows, cols, strict=True)], axis=0)
    sun_prim = stage.GetPrimAtPath(next(p for p, t in lights.items() if t == "DistantLight"))
    travel = -np.array(UsdGeom.Xformable(sun_prim).ComputeLocalToWorldTransform(0.0))[2, :3]
    cos = np.dot(-travel, sun_dir) / np.linalg.norm(sun_dir) / np.linalg.norm(travel)
    assert np.degrees(np.arccos(min(cos, 1.0))) < 2.0
    # distinct saturated colours on the horizon so reflections are readable
    horizon = hdr[50:62][..., ::-1].reshape(-1, 3)
    for channel in range(3):
        others = [c for c in range(3) if c != channel]
        assert np.any(horizon[:, channel] > 5 * horizon[:, others].max(axis=1)), channel

    metals = {}
    for mesh in _meshes(stage).values():
        s = _bound_surface(stage, mesh)
        if s.GetInput("metallic").Get() == 1.0:
            metals[str(mesh.GetPath())] = s.GetInput("roughness").Get()
    assert len(metals) >= 6
    rough = sorted(set(metals.values()))
    assert len(rough) >= 5 and rough[0] <= 0.05 and rough[-1] >= 0.5
    assert _world_points(_meshes(stage)["/World/Geom/TorusKnot"]).min(axis=0)[1] > 0.0  # above the ground


def test_hard_cases_geometry() -> None:
    stage = _open("hard_cases")
    meshes = _meshes(stage)
    pts = {path.rsplit("/", 1)[1] if "FarCopy" not in path else path: _world_points(m) for path, m in meshes.items()}

    assert np.ptp(pts["HugeGround"], axis=0).max() >= 1.0e4
    tiny = pts["TinyCube"]
    assert np.ptp(tiny, axis=0).max() <= 1.5e-3 and tiny[:, 1].min() == pytest.approx(0.0, abs=1e-9)

    # the far copy: same triangles as the probe, 1e5 away, seen by the Far camera
    far_ball = pts["/World/Geom/FarCopy/Ball"]
    np.testing.assert_allclose(far_ball - pts["Ball"], np.tile((1.0e5, 0.0, 0.0), (len(far_ball), 1)), atol=1e-6)
    ndc = _project(_camera(stage, "/World/Cameras/Far"), far_ball)
    assert np.all(np.abs(ndc[:, :2]) < 1.0) and np.all(ndc[:, 2] > 0)
    ndc = _project(_camera(stage, "/World/Cameras/Tiny"), tiny)
    assert np.all(np.abs(ndc[:, :2]) < 1.0) and np.all(ndc[:, 2] > 0)

    # coplanar overlapping quads
    a, b = pts["ZFightA"], pts["ZFightB"]
    assert np.ptp(np.concatenate([a, b])[:, 2]) == 0.0
    overlap = np.minimum(a.max(axis=0), b.max(axis=0)) - np.maximum(a.min(axis=0), b.min(axis=0))
    assert overlap[0] > 0.1 and overlap[1] > 0.1

    # needles and zero-area triangles
    fn, tris = _geometric_normals(meshes["/World/Geom/NeedlesAndDegenerates"])
    area = np.linalg.norm(fn, axis=1) / 2.0
    p = pts["NeedlesAndDegenerates"][tris]
    longest = np.max(np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2), axis=1)
    assert np.sum(area == 0.0) >= 3
    needles = area > 0
    assert np.all(longest[needles] ** 2 / (2 * area[needles]) > 1000.0)

    # thin glass slab
    slab = pts["ThinGlassSlab"]
    assert np.sort(np.ptp(slab, axis=0))[0] == pytest.approx(1.0e-3, rel=1e-3)
    glass = _bound_surface(stage, meshes["/World/Geom/ThinGlassSlab"])
    assert glass.GetInput("opacity").Get() == 0.0 and glass.GetInput("ior").Get() == pytest.approx(1.5)

    # grazing plane: 87 degrees between its normal and the direction to the sun
    sun = next(p for p in stage.Traverse() if p.IsA(UsdLux.DistantLight))
    to_sun = np.array(UsdGeom.Xformable(sun).ComputeLocalToWorldTransform(0.0))[2, :3]
    fn, _ = _geometric_normals(meshes["/World/Geom/GrazingPlane"])
    n = fn[0] / np.linalg.norm(fn[0])
    assert np.degrees(np.arccos(np.dot(n, to_sun) / np.linalg.norm(to_sun))) == pytest.approx(87.0, abs=0.01)

    # polygons with a hole; a left-handed mesh without authored normals
    poly = meshes["/World/Geom/Polygons"]
    assert max(poly.GetFaceVertexCountsAttr().Get()) > 4 and 4 in poly.GetFaceVertexCountsAttr().Get()
    assert list(poly.GetHoleIndicesAttr().Get()) == [1]
    left = meshes["/World/Geom/LeftHanded"]
    assert left.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded and left.GetNormalsAttr().Get() is None

    # texture orientation pattern: uv (0, 0) at the quad's bottom-left; the image's
    # top-left marker is red, bottom-left blue, and it is not symmetric
    quad = meshes["/World/Geom/Orientation"]
    st = np.array(UsdGeom.PrimvarsAPI(quad).GetPrimvar("st").Get())
    q = pts["Orientation"]
    assert np.all(st[np.argmin(q[:, 0] + q[:, 1])] == (0.0, 0.0))
    tex = stage.GetPrimAtPath("/World/Looks/OrientationTex/diffuseTexture")
    img = cv2.imread(tex.GetAttribute("inputs:file").Get().resolvedPath)[..., ::-1]
    assert tuple(img[0, 0]) == (255, 0, 0) and tuple(img[-1, 0]) == (0, 0, 255)
    assert not np.array_equal(img, img[::-1]) and not np.array_equal(img, img[:, ::-1])


def test_textured_animated_spins_and_moves() -> None:
    stage = _open("textured_animated")
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode(), stage.GetTimeCodesPerSecond()) == (0.0, 48.0, 24.0)
    cube = _meshes(stage)["/World/Anim/Cube/Mesh"]
    rot = stage.GetPrimAtPath("/World/Anim/Cube").GetAttribute("xformOp:rotateY")
    assert rot.GetTimeSamples() == [float(f) for f in range(49)]
    p0, p12 = _world_points(cube, 0.0), _world_points(cube, 12.0)
    c, s = np.cos(np.radians(90.0)), np.sin(np.radians(90.0))
    centre = np.array([0.0, 0.3, 0.0])
    expected = (p0 - centre) @ np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]) + centre  # rotateY(90) on row vectors
    np.testing.assert_allclose(p12, expected, atol=1e-5)
    assert _bound_surface(stage, cube).GetInput("diffuseColor").HasConnectedSource()
    moving = [_camera(stage, "/World/Cameras/AnimCam", t).transform.ExtractTranslation() for t in (0.0, 48.0)]
    assert np.linalg.norm(np.array(moving[0]) - np.array(moving[1])) > 1.0


def _load_script():
    spec = importlib.util.spec_from_file_location("make_scenes", ROOT / "scripts" / "make_scenes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_script_regenerates_identical_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _load_script().main([str(tmp_path)]) == 0
    produced = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert produced == sorted(GENERATED)
    for rel in GENERATED:
        fresh, shipped = (tmp_path / rel).read_bytes(), (SCENES / rel).read_bytes()
        assert fresh == shipped, f"{rel} differs: rerun scripts/make_scenes.py"
