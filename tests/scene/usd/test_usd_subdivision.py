"""Subdivision surfaces: catmullClark / loop / bilinear refinement with creases and corners."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, Vt
from usd_stage_kit import add_mesh, bind, mesh_world_points, new_stage, preview_material

from warp_hybrid.scene.model import Camera
from warp_hybrid.scene.usd import subdivision
from warp_hybrid.scene.usd.loader import UsdSceneSource, load_scene
from warp_hybrid.scene.usd.subdivision import Sharpness, refine
from warp_hybrid.scene.usd.subdivision_level import (
    MAX_AUTO_LEVELS,
    TARGET_EDGE_PX,
    auto_level,
    cage_edge_px,
    cage_edges,
)

CUBE_POINTS = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]  # outward, CCW
CUBE_EDGES = sorted({tuple(sorted((f[i], f[(i + 1) % 4]))) for f in CUBE_FACES for i in range(4)})
OCTAHEDRON = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]


def _outward(tris: list[list[int]], points: list[tuple]) -> list[list[int]]:
    """``tris`` of a convex solid around the origin, each wound counter-clockwise outward."""
    p = np.array(points, dtype=np.float64)
    return [t if np.cross(p[t[1]] - p[t[0]], p[t[2]] - p[t[0]]) @ p[t].sum(0) > 0 else t[::-1] for t in tris]


OCTAHEDRON_FACES = _outward([[a, b, c] for a in (0, 1) for b in (2, 3) for c in (4, 5)], OCTAHEDRON)


def _cube(stage, path: str = "/World/Cube", scheme: str | None = "catmullClark", **attrs) -> UsdGeom.Mesh:
    return add_mesh(stage, path, CUBE_POINTS, [4] * 6, np.ravel(CUBE_FACES), subdivision=scheme, **attrs)


def _load(tmp_path, build, levels: int = 1):
    stage, path = new_stage(tmp_path)
    build(stage)
    stage.GetRootLayer().Save()
    return load_scene(path, subdivision_levels=levels)


def _refine_cube(levels: int, sharpness: Sharpness | None = None) -> np.ndarray:
    r = refine("catmullClark", np.full(6, 4), np.ravel(CUBE_FACES), 8, sharpness or Sharpness.smooth(), levels)
    return r.vertex_values(np.array(CUBE_POINTS, dtype=np.float64))


def _on_cube_edges(points: np.ndarray) -> np.ndarray:
    """The points with at least two coordinates on the cube's faces (|c| = 0.5)."""
    return points[(np.abs(np.abs(points) - 0.5) < 1e-6).sum(axis=1) >= 2]


def test_catmull_clark_cube_converges_to_its_limit_surface(tmp_path):
    limit = _refine_cube(7)  # a refined vertex keeps its index: limit[:n] are level-L vertices' limits
    corner = (9 * np.array(CUBE_POINTS[0]) + 4 * np.array(CUBE_POINTS)[[1, 2, 4]].sum(0)) / 24
    corner += np.array(CUBE_POINTS)[[3, 5, 6]].sum(0) / 24  # the valence-3 limit mask: (n^2 v + 4 E + F) / n(n+5)
    np.testing.assert_allclose(corner, (-0.25, -0.25, -0.25))
    np.testing.assert_allclose(limit[0], corner, atol=1e-4)
    errors = []
    for levels in (1, 2, 3):
        scene = _load(tmp_path / str(levels), _cube, levels)
        points = mesh_world_points(scene, "/World/Cube")
        assert scene.triangle_count == 2 * 6 * 4**levels
        errors.append(np.linalg.norm(points - limit[: len(points)], axis=1).max())
        normals = scene.corner_normals.reshape(-1, 3)
        assert (np.einsum("ij,ij->i", normals, points[scene.indices].reshape(-1, 3)) > 0).all()  # outward
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01


def test_infinitely_sharp_cube_stays_a_cube_and_an_uncreased_one_rounds_off(tmp_path):
    edges = np.ravel(CUBE_EDGES)

    def creased(stage):
        _cube(stage, CreaseIndices=Vt.IntArray(edges.tolist()), CreaseLengths=[2] * 12, CreaseSharpnesses=[10.0] * 12)

    sharp = _load(tmp_path / "sharp", creased, 2)
    points = mesh_world_points(sharp, "/World/Cube")
    np.testing.assert_allclose(np.abs(points).max(axis=1), 0.5, atol=1e-6)  # every face stays flat
    assert len(_on_cube_edges(points)) == 8 + 12 * 3  # the edges stay straight, their points on them
    normals = sharp.corner_normals.reshape(-1, 3)
    np.testing.assert_allclose(np.abs(normals).max(axis=1), 1.0, atol=1e-6)  # split along the creases

    smooth = _load(tmp_path / "smooth", _cube, 2)
    points = mesh_world_points(smooth, "/World/Cube")
    assert np.abs(points).max() < 0.5 - 1e-3 and not len(_on_cube_edges(points))
    assert np.abs(smooth.corner_normals.reshape(-1, 3)).max(axis=1).min() < 0.9


def test_creased_edge_between_sharp_corners_stays_straight(tmp_path):
    def one_edge(stage):  # the edge 0-1 (x = y = -0.5), per-edge sharpness, both ends corners
        _cube(
            stage,
            CreaseIndices=[0, 1],
            CreaseLengths=[2],
            CreaseSharpnesses=[10.0],
            CornerIndices=[0, 1],
            CornerSharpnesses=[10.0, 10.0],
        )

    points = mesh_world_points(_load(tmp_path, one_edge, 2), "/World/Cube")
    on_edge = points[(np.abs(points[:, 0] + 0.5) < 1e-6) & (np.abs(points[:, 1] + 0.5) < 1e-6)]
    np.testing.assert_allclose(np.sort(on_edge[:, 2]), [-0.5, -0.25, 0.0, 0.25, 0.5], atol=1e-6)
    opposite = np.linalg.norm(points - (0.5, 0.5, 0.0), axis=1).min()  # the parallel edge 6-7 rounds off
    assert opposite > 0.1


def test_semi_sharp_crease_lies_between_smooth_and_sharp():
    edge = CUBE_EDGES.index((0, 1))
    reach = []
    for s in (0.0, 0.5, 1.0, 2.0):
        sharpness = Sharpness(np.array([[0, 1]]), np.array([s]), np.zeros(0, int), np.zeros(0))
        points = _refine_cube(2, sharpness)
        middle = 8 + edge  # the edge's level-1 point is a vertex of level 2
        reach.append(np.linalg.norm(points[middle, :2]))
    assert reach[0] < reach[1] < reach[2] < reach[3] <= np.sqrt(0.5) + 1e-9


def test_loop_octahedron_shrinks_toward_its_limit(tmp_path):
    def octahedron(stage):
        add_mesh(stage, "/World/Oct", OCTAHEDRON, [3] * 8, np.ravel(OCTAHEDRON_FACES), subdivision="loop")

    r = refine("loop", np.full(8, 3), np.ravel(OCTAHEDRON_FACES), 6, Sharpness.smooth(), 7)
    limit = r.vertex_values(np.array(OCTAHEDRON, dtype=np.float64))
    beta = (5 / 8 - (3 / 8 + np.cos(2 * np.pi / 4) / 4) ** 2) / 4
    omega = 1 / (4 + 3 / (8 * beta))  # Loop's limit mask, valence 4: (1 - n w) v + w sum(neighbours)
    np.testing.assert_allclose(limit[0], (1 - 4 * omega, 0, 0), atol=1e-4)
    errors, radius = [], []
    for levels in (1, 2, 3):
        scene = _load(tmp_path / str(levels), octahedron, levels)
        points = mesh_world_points(scene, "/World/Oct")
        assert scene.triangle_count == 8 * 4**levels
        errors.append(np.linalg.norm(points - limit[: len(points)], axis=1).max())
        radius.append(np.linalg.norm(points[:6], axis=1).max())
    assert errors[0] > errors[1] > errors[2]
    assert 1.0 > radius[0] > radius[1] > radius[2] > 1 - 4 * omega


def test_primvars_and_material_subsets_follow_the_refinement(tmp_path):
    pts = [(x, y, 0) for y in (0, 1) for x in (0, 1, 2)]
    fvi = [0, 1, 4, 3, 1, 2, 5, 4]

    def strips(stage):  # two quads each; a regular planar grid refines onto its own plane, evenly
        for name, interpolation, uvs in (("V", "vertex", pts), ("F", "faceVarying", [pts[i] for i in fvi])):
            mesh = add_mesh(stage, f"/World/{name}", pts, [4, 4], fvi, subdivision="catmullClark")
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interpolation)
            st.Set(Vt.Vec2fArray([Gf.Vec2f(x, y) for x, y, _ in uvs]))
            red, _ = preview_material(stage, "/World/Looks/Red", diffuseColor=(1.0, 0.0, 0.0))
            blue, _ = preview_material(stage, "/World/Looks/Blue", diffuseColor=(0.0, 0.0, 1.0))
            bind(mesh, red)
            subset = UsdGeom.Subset.CreateGeomSubset(
                mesh, "right", UsdGeom.Tokens.face, Vt.IntArray([1]), "materialBind"
            )
            bind(subset, blue)

    scene = _load(tmp_path, strips)
    corners = scene.points[scene.indices].astype(np.float64) + scene.origin
    assert scene.triangle_count == 2 * 16
    np.testing.assert_allclose(scene.corner_uvs, corners[..., :2], atol=1e-6)  # st refined with the points
    names = np.array([scene.materials[i].name for i in scene.triangle_material])
    right = corners[..., 0].mean(axis=1) > 1
    assert (names[right] == "/World/Looks/Blue").all() and (names[~right] == "/World/Looks/Red").all()


def test_unauthored_none_and_level_zero_stay_the_control_cage(tmp_path):
    scene = _load(tmp_path / "unauthored", lambda s: _cube(s, scheme=None))
    assert scene.triangle_count == 12
    assert any("do not author subdivisionScheme" in w and "/World/Cube" in w for w in scene.warnings)
    assert _load(tmp_path / "none", lambda s: _cube(s, scheme="none")).triangle_count == 12
    assert _load(tmp_path / "zero", _cube, levels=0).triangle_count == 12
    with pytest.raises(ValueError, match="subdivision_levels"):
        load_scene(tmp_path / "zero" / "scene.usda", subdivision_levels=-1)


@pytest.mark.parametrize(
    ("attrs", "message"),
    [
        ({"CreaseIndices": [0, 1, 3], "CreaseLengths": [2], "CreaseSharpnesses": [2.0]}, "creaseLengths sum to 2"),
        ({"CreaseIndices": [0, 9], "CreaseLengths": [2], "CreaseSharpnesses": [2.0]}, "outside the 8 points"),
        ({"CreaseIndices": [0, 1], "CreaseLengths": [2], "CreaseSharpnesses": [1.0, 2.0, 3.0]}, "expected 1"),
        ({"CreaseIndices": [0, 7], "CreaseLengths": [2], "CreaseSharpnesses": [2.0]}, "not edges of the mesh"),
        ({"CornerIndices": [0, 1], "CornerSharpnesses": [2.0]}, "cornerSharpnesses 1"),
    ],
)
def test_bad_sharpness_data_is_warned_about_and_ignored(tmp_path, attrs, message):
    scene = _load(tmp_path, lambda s: _cube(s, **attrs))
    assert scene.triangle_count == 48
    assert any(w.startswith("/World/Cube: ") and message in w for w in scene.warnings), scene.warnings
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Cube"), _refine_cube(1), atol=1e-6)


def test_loop_on_quads_unsupported_rules_and_the_face_budget_are_reported(tmp_path, monkeypatch):
    scene = _load(tmp_path / "loop", lambda s: _cube(s, scheme="loop"))
    assert scene.triangle_count == 12
    assert "/World/Cube: subdivisionScheme 'loop' needs a triangle mesh; rendered as its control cage" in scene.warnings
    scene = _load(tmp_path / "rules", lambda s: _cube(s, InterpolateBoundary="none", TriangleSubdivisionRule="smooth"))
    assert scene.triangle_count == 48
    assert any("interpolateBoundary 'none' is not supported" in w for w in scene.warnings)
    assert any("triangleSubdivisionRule 'smooth' is not supported" in w for w in scene.warnings)
    monkeypatch.setattr(subdivision, "MAX_REFINED_FACES", 100)
    scene = _load(tmp_path / "budget", _cube, levels=3)
    assert scene.triangle_count == 2 * 96
    assert any("subdivided 2 levels instead of 3" in w for w in scene.warnings)


def test_bilinear_cube_keeps_flat_faces_and_face_normals(tmp_path):
    scene = _load(tmp_path, lambda s: _cube(s, scheme="bilinear"), 2)
    points = mesh_world_points(scene, "/World/Cube")
    assert scene.triangle_count == 2 * 6 * 16
    np.testing.assert_allclose(np.abs(points).max(axis=1), 0.5, atol=1e-6)
    np.testing.assert_allclose(np.abs(scene.corner_normals.reshape(-1, 3)).max(axis=1), 1.0, atol=1e-6)


def test_holes_drop_the_refined_faces_of_their_control_face(tmp_path):
    scene = _load(tmp_path, lambda s: _cube(s, HoleIndices=[0]))
    assert scene.triangle_count == 48 - 8
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Cube"), _refine_cube(1), atol=1e-6)


def test_animated_control_points_refine_at_every_time(tmp_path):
    stage, path = new_stage(tmp_path)
    mesh = _cube(stage)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE_POINTS]), 0.0)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*(2 * np.array(p))) for p in CUBE_POINTS]), 10.0)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path, subdivision_levels=1)
    first = source.scene_at(0.0)
    later = source.scene_at(10.0)
    assert first.meshes[0].animated
    np.testing.assert_allclose(mesh_world_points(later, "/World/Cube"), 2 * _refine_cube(1), atol=1e-6)
    np.testing.assert_array_equal(later.indices, first.indices)


def _camera_at(z: float, tan_half_fov_x: float = 0.5) -> Camera:
    """A camera on the +Z axis looking down -Z (focal length 1 mm, aperture 2 tan)."""
    m = np.eye(4)
    m[2, 3] = z
    return Camera("/Cam", cam_to_world=m, focal_length=1.0, horizontal_aperture=2.0 * tan_half_fov_x)


def test_auto_level_halves_the_edge_down_to_the_target():
    """Each level halves an edge: a 4-pixel edge needs 1 (the least), 8.1 pixels 2,
    16 pixels 2, 32.5 pixels 4 -> 4 levels is the most."""
    assert [auto_level(e) for e in (0.0, TARGET_EDGE_PX, 8.0, 8.1, 16.0, 16.5, 32.0)] == [1, 1, 1, 2, 2, 3, 3]
    assert auto_level(1e9) == auto_level(float("inf")) == MAX_AUTO_LEVELS


def test_cage_edge_px_is_the_mean_edge_over_the_pixel_footprint_at_the_nearest_instance():
    """The unit cube's 12 edges of length 1 (each face edge counted twice), its near face
    at distance d: the pixel footprint there is 2 d tan / width; the nearer instance counts."""
    edges = cage_edges(np.array([4] * 6), np.ravel(CUBE_FACES))
    assert edges.shape == (24, 2)
    assert {tuple(sorted(e)) for e in edges.tolist()} == set(CUBE_EDGES)
    camera = _camera_at(10.5)
    near, far = np.eye(4), np.eye(4)
    far[3, 2] = -20.0  # row-vector transforms: the translation is the last row
    px = cage_edge_px(
        np.array(CUBE_POINTS), np.array([4] * 6), np.ravel(CUBE_FACES), np.stack([far, near]), camera, 640
    )
    np.testing.assert_allclose(px, 1.0 / (2.0 * 10.0 * 0.5 / 640), rtol=1e-9)
    inside = cage_edge_px(
        np.array(CUBE_POINTS), np.array([4] * 6), np.ravel(CUBE_FACES), near[None], _camera_at(0.0), 640
    )
    np.testing.assert_allclose(inside, 1.0 / (2.0 * camera.near * 0.5 / 640), rtol=1e-9)


def _camera_stage(tmp_path, distance: float):
    stage, path = new_stage(tmp_path)
    _cube(stage)
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, distance))
    stage.GetRootLayer().Save()
    return path


@pytest.mark.parametrize(
    ("distance", "width", "expected"), [(60.5, 320, 1), (40.5, 320, 2), (20.5, 320, 3), (20.5, 1280, 4), (0.6, 640, 4)]
)
def test_auto_levels_follow_the_size_on_the_screen(tmp_path, distance, width, expected):
    """The default (AUTO) level of the cube seen from ``distance`` on a ``width``-pixel
    screen is the level the formula gives (tan(hfov / 2) = 0.36; inside the near plane,
    1 unit by USD's fallback clippingRange, the footprint there): 4^L quads a face."""
    path = _camera_stage(tmp_path, distance)
    edge_px = 1.0 / (2.0 * max(distance - 0.5, 1.0) * 0.36 / width)
    levels = auto_level(edge_px)
    assert levels == expected
    scene = load_scene(path, screen=(width, width * 3 // 4))
    assert scene.triangle_count == 12 * 4**levels
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Cube"), _refine_cube(levels), atol=1e-6)


def test_auto_level_is_kept_while_the_mesh_moves(tmp_path):
    """Chosen once (at the first time evaluated), so the topology never changes: the cube
    flying toward the camera keeps its level and its index array."""
    stage, path = new_stage(tmp_path)
    mesh = _cube(stage)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in CUBE_POINTS]), 0.0)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(p[0], p[1], p[2] + 50.0) for p in CUBE_POINTS]), 10.0)
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 60.5))
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path, screen=(320, 240))
    first = source.scene_at(0.0)
    later = source.scene_at(10.0)
    assert first.triangle_count == later.triangle_count == 12 * 4 ** auto_level(1.0 / (2.0 * 60.0 * 0.36 / 320))
    np.testing.assert_array_equal(later.indices, first.indices)
