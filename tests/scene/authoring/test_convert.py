"""`warp-hybrid convert`: mesh files through trimesh to USD, checked with pxr alone."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom, UsdShade

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.authoring.convert import MESH_SUFFIXES, convert_mesh_file, mesh_file_to_stage

# 2x2 RGB image, row 0 = top: red, green / blue, yellow
QUAD_IMAGE = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 0]]], np.uint8)


def _meshes(stage: Usd.Stage) -> list[UsdGeom.Mesh]:
    return [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]


def _world_points(mesh: UsdGeom.Mesh) -> np.ndarray:
    m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
    p = np.array(mesh.GetPointsAttr().Get(), dtype=np.float64)
    return p @ m[:3, :3] + m[3, :3]


def _triangles(stage: Usd.Stage) -> int:
    total = 0
    for mesh in _meshes(stage):
        counts = np.array(mesh.GetFaceVertexCountsAttr().Get())
        assert np.all(counts == 3)
        total += len(counts)
    return total


def _surface(stage: Usd.Stage, mesh: UsdGeom.Mesh) -> UsdShade.Shader:
    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    assert material, f"{mesh.GetPath()} has no material"
    return UsdShade.Shader(stage.GetPrimAtPath(material.GetPath().AppendChild("PreviewSurface")))


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


@pytest.fixture()
def box_obj(tmp_path: Path) -> tuple[Path, trimesh.Trimesh]:
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.apply_translation((0.5, -1.0, 4.0))
    path = tmp_path / "src" / "box.ply"
    path.parent.mkdir()
    box.export(path)
    return path, box


@pytest.mark.parametrize("ext", [".usda", ".usdc"])
def test_box_converts_with_matching_triangles_and_bounds(box_obj, tmp_path: Path, ext: str) -> None:
    src, box = box_obj
    dst = tmp_path / "out" / f"box{ext}"
    convert_mesh_file(src, dst)
    stage = Usd.Stage.Open(str(dst))
    assert stage.GetRootLayer().GetFileFormat().formatId == ext[1:]
    assert UsdGeom.GetStageUpAxis(stage) == "Y"
    assert _triangles(stage) == 12
    (mesh,) = _meshes(stage)
    pts = _world_points(mesh)
    np.testing.assert_allclose(pts.min(axis=0), box.bounds[0], atol=1e-6)
    np.testing.assert_allclose(pts.max(axis=0), box.bounds[1], atol=1e-6)
    normals = np.array(mesh.GetNormalsAttr().Get())
    assert mesh.GetNormalsInterpolation() == UsdGeom.Tokens.vertex and len(normals) == len(pts)
    # renders as is: a camera that sees the bounds centre, a sun and a sky
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/World/Cameras/Main"))
    gf_cam = cam.GetCamera(Usd.TimeCode.Default())
    to_centre = box.bounds.mean(axis=0) - np.array(gf_cam.transform.ExtractTranslation())
    forward = -np.array(gf_cam.transform.GetRow3(2))
    assert np.dot(to_centre, forward) / np.linalg.norm(to_centre) == pytest.approx(1.0, abs=1e-6)
    kinds = sorted(p.GetTypeName() for p in stage.Traverse() if "Light" in p.GetTypeName())
    assert kinds == ["DistantLight", "DomeLight"]


def test_in_memory_stage_matches_file(box_obj) -> None:
    src, box = box_obj
    stage = mesh_file_to_stage(src)
    assert stage.GetRootLayer().anonymous
    assert _triangles(stage) == 12
    np.testing.assert_allclose(_world_points(_meshes(stage)[0]).max(axis=0), box.bounds[1], atol=1e-6)


@pytest.mark.parametrize("suffix", MESH_SUFFIXES)
def test_every_listed_mesh_suffix_is_read(box_obj, tmp_path: Path, suffix: str) -> None:
    _, box = box_obj
    src = tmp_path / f"box{suffix}"
    box.export(src)
    stage = mesh_file_to_stage(src, texture_dir=tmp_path / "tex")
    assert _triangles(stage) == 12


def test_gltf_node_transforms_are_baked(tmp_path: Path) -> None:
    scene = trimesh.Scene()
    a = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    b = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    scene.add_geometry(a, node_name="A", transform=trimesh.transformations.translation_matrix((3.0, 0.0, 0.0)))
    rot = trimesh.transformations.rotation_matrix(np.pi / 2, (0, 0, 1))
    scale = np.diag([2.0, 2.0, 2.0, 1.0])
    scene.add_geometry(b, node_name="B", transform=rot @ scale)
    src = tmp_path / "two.glb"
    scene.export(src)
    stage = mesh_file_to_stage(src)
    meshes = {m.GetPrim().GetName(): m for m in _meshes(stage)}
    assert sorted(meshes) == ["A", "B"]
    assert _triangles(stage) == len(a.faces) + len(b.faces)
    pa = _world_points(meshes["A"])
    np.testing.assert_allclose(pa.min(axis=0), (2.5, -0.5, -0.5), atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(_world_points(meshes["B"]), axis=1), 1.0, atol=1e-5)


def _write_textured_gltf(path: Path, **material_extra: object) -> None:
    """A unit quad in the XY plane at x + 2 with glTF uvs (0, 0) = top-left of the image,
    a 2x2 base colour texture, baseColorFactor (0.5, 0.25, 1, 1), metallic 0.25, roughness 0.7
    (plus ``material_extra`` fields in the material)."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    buf = pos.tobytes() + uv.tobytes() + idx.tobytes()
    ok, png = cv2.imencode(".png", QUAD_IMAGE[..., ::-1])
    assert ok
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "Quad", "translation": [2.0, 0.0, 0.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [
            {
                "name": "Tex",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.5, 0.25, 1.0, 1.0],
                    "baseColorTexture": {"index": 0},
                    "metallicFactor": 0.25,
                    "roughnessFactor": 0.7,
                },
                **material_extra,
            }
        ],
        "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(png.tobytes()).decode()}],
        "buffers": [
            {"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }
    path.write_text(json.dumps(gltf))


def _sample_nearest(image_rgb: np.ndarray, st: np.ndarray) -> np.ndarray:
    """Texel at USD uv ``st`` ((0, 0) = bottom-left), nearest, clamped."""
    h, w = image_rgb.shape[:2]
    col = min(int(st[0] * w), w - 1)
    row = min(int((1.0 - st[1]) * h), h - 1)
    return image_rgb[row, col]


@pytest.mark.parametrize("container", ["gltf", "glb"])
def test_gltf_base_colour_and_texture_round_trip(tmp_path: Path, container: str) -> None:
    src = tmp_path / "quad.gltf"
    _write_textured_gltf(src)
    if container == "glb":  # same content re-packed as a binary GLB with the image embedded
        glb = tmp_path / "quad.glb"
        trimesh.load(src, force="scene").export(glb)
        src = glb
    dst = tmp_path / "out" / "quad.usda"
    convert_mesh_file(src, dst)
    stage = Usd.Stage.Open(str(dst))
    (mesh,) = _meshes(stage)
    surface = _surface(stage, mesh)
    assert surface.GetInput("metallic").Get() == pytest.approx(0.25)
    assert surface.GetInput("roughness").Get() == pytest.approx(0.7)
    source = surface.GetInput("diffuseColor").GetConnectedSource()[0]
    tex = UsdShade.Shader(source.GetPrim())
    assert tex.GetIdAttr().Get() == "UsdUVTexture"
    np.testing.assert_allclose(tex.GetInput("scale").Get(), (0.5, 0.25, 1.0, 1.0), atol=1.0 / 255.0)
    asset = tex.GetInput("file").Get()
    assert not Path(asset.path).is_absolute() and asset.path.startswith("textures/")
    image = cv2.imread(asset.resolvedPath, cv2.IMREAD_COLOR)[..., ::-1]
    np.testing.assert_array_equal(image, QUAD_IMAGE)
    # orientation: the glTF vertex with uv (0, 0) (image top-left, red) is the quad's
    # top-left corner (2, 1, 0); in USD its st must address the same red texel
    pts = _world_points(mesh)
    st = np.array(UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st").Get())
    corner = int(np.argmin(np.linalg.norm(pts - (2.0, 1.0, 0.0), axis=1)))
    np.testing.assert_allclose(st[corner], (0.0, 1.0), atol=1e-6)
    for k in range(4):
        gltf_uv = ((pts[k, 0] - 2.0), 1.0 - pts[k, 1])  # how the source file mapped this corner
        expected = QUAD_IMAGE[min(int(gltf_uv[1] * 2), 1), min(int(gltf_uv[0] * 2), 1)]
        np.testing.assert_array_equal(_sample_nearest(image, st[k]), expected)


def test_gltf_alpha_mask_emission_and_double_sided(tmp_path: Path) -> None:
    src = tmp_path / "masked.gltf"
    _write_textured_gltf(src, alphaMode="MASK", alphaCutoff=0.3, emissiveFactor=[1.0, 0.5, 0.0], doubleSided=True)
    stage = mesh_file_to_stage(src, texture_dir=tmp_path / "tex")
    (mesh,) = _meshes(stage)
    surface = _surface(stage, mesh)
    assert surface.GetInput("opacityThreshold").Get() == pytest.approx(0.3)
    assert surface.GetInput("opacity").Get() == pytest.approx(1.0)
    np.testing.assert_allclose(surface.GetInput("emissiveColor").Get(), (1.0, 0.5, 0.0))
    assert mesh.GetDoubleSidedAttr().Get() is True


def test_obj_with_mtl_keeps_colour_roughness_uvs_and_texture(tmp_path: Path) -> None:
    src = tmp_path / "tri.obj"
    cv2.imwrite(str(tmp_path / "tex.png"), QUAD_IMAGE[..., ::-1])
    (tmp_path / "tri.mtl").write_text("newmtl Paint\nKd 0.2 0.4 0.6\nNs 30\nmap_Kd tex.png\n")
    src.write_text(
        "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
        "usemtl Paint\nf 1/1/1 2/2/1 3/3/1\n"
    )
    dst = tmp_path / "tri.usdc"
    convert_mesh_file(src, dst)
    stage = Usd.Stage.Open(str(dst))
    (mesh,) = _meshes(stage)
    surface = _surface(stage, mesh)
    assert surface.GetInput("metallic").Get() == 0.0
    assert surface.GetInput("roughness").Get() == pytest.approx((2.0 / 32.0) ** 0.25, rel=1e-6)
    np.testing.assert_allclose(surface.GetInput("diffuseColor").Get(), (0.2, 0.4, 0.6), atol=1.0 / 255.0)
    st = np.array(UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st").Get())
    pts = _world_points(mesh)
    np.testing.assert_allclose(st, pts[:, :2], atol=1e-6)  # this file's uvs equal x, y
    np.testing.assert_allclose(np.array(mesh.GetNormalsAttr().Get()), [[0, 0, 1]] * 3, atol=1e-6)
    source = surface.GetInput("diffuseColor").GetConnectedSource()[0]
    written = UsdShade.Shader(source.GetPrim()).GetInput("file").Get().resolvedPath
    np.testing.assert_array_equal(cv2.imread(written)[..., ::-1], QUAD_IMAGE)


def test_ply_vertex_colours_become_linear_display_color(tmp_path: Path) -> None:
    mesh = trimesh.Trimesh(
        vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        faces=[[0, 1, 2]],
        vertex_colors=[[255, 0, 0, 255], [0, 128, 0, 255], [0, 0, 0, 255]],
        process=False,
    )
    src = tmp_path / "coloured.ply"
    mesh.export(src)
    stage = mesh_file_to_stage(src)
    (usd_mesh,) = _meshes(stage)
    colours = np.array(usd_mesh.GetDisplayColorPrimvar().Get())
    srgb_128 = ((128 / 255 + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(colours, [[1, 0, 0], [0, srgb_128, 0], [0, 0, 0]], atol=1e-6)
    assert not UsdShade.MaterialBindingAPI(usd_mesh.GetPrim()).ComputeBoundMaterial()[0]


def test_in_memory_textures_go_to_the_given_folder(tmp_path: Path) -> None:
    src = tmp_path / "quad.gltf"
    _write_textured_gltf(src)
    stage = mesh_file_to_stage(src, texture_dir=tmp_path / "tex")
    tex = stage.GetPrimAtPath("/World/Looks/Tex/diffuseTexture")
    path = Path(tex.GetAttribute("inputs:file").Get().path)
    assert path.is_absolute() and path.parent == (tmp_path / "tex").resolve() and path.is_file()


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("missing.obj", None, "not found"),
        ("model.xyz", "1 2 3\n", "unsupported mesh format"),
        ("empty.obj", "# nothing here\n", "no triangles"),
        ("broken.glb", "definitely not a glb", "cannot read"),
    ],
)
def test_bad_input_names_the_file_and_leaves_nothing(
    tmp_path: Path, name: str, content: str | None, problem: str
) -> None:
    src = tmp_path / "in" / name
    src.parent.mkdir()
    if content is not None:
        src.write_text(content)
    out = tmp_path / "out"
    out.mkdir()
    (out / "scene.usda").write_text("previous")
    with pytest.raises(SceneError) as err:
        convert_mesh_file(src, out / "scene.usda")
    assert str(src) in str(err.value) and problem in str(err.value)
    assert err.value.path == str(src)
    assert _files(out) == {"scene.usda"} and (out / "scene.usda").read_text() == "previous"
    with pytest.raises(SceneError, match=problem):
        mesh_file_to_stage(src)


@pytest.mark.parametrize("ext", [".usdz", ".obj", ""])
def test_unsupported_output_extension(box_obj, tmp_path: Path, ext: str) -> None:
    src, _ = box_obj
    dst = tmp_path / f"out{ext}"
    with pytest.raises(SceneError, match="unsupported output extension") as err:
        convert_mesh_file(src, dst)
    assert err.value.path == str(dst)
    assert not dst.exists()


def test_failed_write_leaves_no_temporary_file(box_obj, tmp_path: Path) -> None:
    src, _ = box_obj
    out = tmp_path / "out"
    (out / "scene.usda").mkdir(parents=True)  # the destination name is taken by a folder
    with pytest.raises(SceneError, match="cannot write") as err:
        convert_mesh_file(src, out / "scene.usda")
    assert str(out / "scene.usda") in str(err.value)
    assert _files(out) == {"scene.usda"}
