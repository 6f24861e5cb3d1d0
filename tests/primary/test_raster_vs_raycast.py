"""The raster G-buffer equals the ray-cast reference except on silhouettes, on an
analytic scene and on real shared scenes; thread count never changes the result."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from warp_hybrid.core.gbuffer import CHANNELS, GBuffer
from warp_hybrid.core.native_rows import CHUNK_CPU
from warp_hybrid.primary.kernels import SHORT_RUN_PIXELS
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Camera, Material, Scene

GBUFFER_FIELDS = tuple(c.name for c in CHANNELS)


def _analytic_scene(rings: int = 24, segments: int = 48) -> tuple[Scene, Camera]:
    meshes = [
        quad((-6.0, 0.0, 6.0), (12.0, 0.0, 0.0), (0.0, 0.0, -12.0), 0, "/floor"),
        uv_sphere((0.0, 0.8, 0.0), 0.8, rings=rings, segments=segments, material=1, name="/ball"),
        uv_sphere((1.6, 0.4, 0.9), 0.4, rings=12, segments=24, material=2, name="/small"),
        quad((-2.5, 0.0, -1.5), (1.2, 0.0, -0.6), (0.0, 1.8, 0.0), 2, "/panel"),
    ]
    materials = [
        Material("floor", diffuse=(0.6, 0.6, 0.6)),
        Material("ball", diffuse=(0.8, 0.2, 0.1), metallic=0.5),
        Material("panel"),
    ]
    cam = look_at_camera((2.5, 2.0, 4.5), (0.0, 0.6, 0.0), hfov_deg=55.0)
    return make_scene(meshes, materials, cameras=[cam]), cam


def _mesh_labels(scene: Scene, tri: np.ndarray) -> np.ndarray:
    """Per pixel: which source mesh was hit (-1 for background)."""
    of_triangle = np.empty(scene.triangle_count, np.int64)
    for k, m in enumerate(scene.meshes):
        of_triangle[m.first_triangle : m.first_triangle + m.triangle_count] = k
    return np.where(tri >= 0, of_triangle[np.maximum(tri, 0)], -1)


def _compare(scene: Scene, a: GBuffer, b: GBuffer) -> dict[str, float]:
    """Agreement of raster (a) and ray cast (b) away from silhouettes (pixels whose
    3x3 neighbourhood in the ray cast sees more than one mesh or the background)."""
    tb = b.triangle_id.numpy()
    labels = _mesh_labels(scene, tb)
    silhouette = ndimage.maximum_filter(labels, 3) != ndimage.minimum_filter(labels, 3)
    keep = ~silhouette & (tb >= 0)
    ta = a.triangle_id.numpy()
    da, db = a.depth.numpy()[keep], b.depth.numpy()[keep]
    na, nb = a.normal.numpy()[keep], b.normal.numpy()[keep]
    same = ta[keep] == tb[keep]
    # Both paths take the hit record of the triangle they found from ``exact_hit`` on the
    # pixel's ray (the raster's resolve in a native row loop, the ray cast per pixel).
    found = (ta == tb) & (tb >= 0)
    bits = [
        np.array_equal(c.numpy()[found].view(np.uint32), d.numpy()[found].view(np.uint32))
        for c, d in ((a.depth, b.depth), (a.barycentric, b.barycentric))
    ]
    return {
        "same_hit_bits": float(all(bits)),
        "pixels": float(keep.sum()),
        "silhouette_share": float(silhouette.mean()),
        "same_triangle": float(same.mean()),
        "depth_agree": float((np.abs(da - db) <= 1e-4 * db).mean()),
        "normal_agree": float((np.einsum("ij,ij->i", na, nb) >= 0.999).mean()),
        "background_agree": float(((ta < 0) == (tb < 0))[~silhouette].mean()),
        "material_agree": float((a.material_id.numpy()[keep] == b.material_id.numpy()[keep]).mean()),
    }


def test_raster_matches_raycast_on_an_analytic_scene(device: str, render) -> None:
    scene, cam = _analytic_scene()
    a = render(scene, cam, 160, 120, device, "raster")
    b = render(scene, cam, 160, 120, device, "raycast")
    s = _compare(scene, a, b)
    assert s["pixels"] > 10000
    assert s["background_agree"] == 1.0
    assert s["depth_agree"] == 1.0
    assert s["normal_agree"] == 1.0
    assert s["material_agree"] == 1.0
    assert s["same_triangle"] >= 0.995  # differences only where a pixel centre lies on an inner edge
    assert s["same_hit_bits"] == 1.0
    # the resolve's chunks took both ways to their corners: gathered per pixel where runs of
    # pixels on one triangle are short (the balls), once a run elsewhere (the floor)
    tris = a.triangle_id.numpy()[:, : 160 - 160 % CHUNK_CPU].reshape(120, -1, CHUNK_CPU)
    runs = 1 + (tris[..., 1:] != tris[..., :-1]).sum(axis=-1)
    hit_chunks = (tris >= 0).any(axis=-1)
    short = runs * SHORT_RUN_PIXELS > CHUNK_CPU
    assert (short & hit_chunks).any() and (~short & hit_chunks).any()
    same = a.triangle_id.numpy() == b.triangle_id.numpy()
    for name in ("position", "albedo", "specular", "optics"):
        got, want = a.channel_numpy(name)[same], b.channel_numpy(name)[same]
        np.testing.assert_allclose(got, want, atol=2e-5, err_msg=name)


@pytest.mark.parametrize("name", ["smoke_test", "cornell_box_glass_mirror"])
def test_raster_matches_raycast_on_shared_scenes(device: str, render, shared_scenes, name: str) -> None:
    loader = pytest.importorskip("warp_hybrid.scene.usd.loader")
    import json

    entry = {s["name"]: s for s in json.loads((shared_scenes / "manifest.json").read_text())["scenes"]}[name]
    scene = loader.load_scene(shared_scenes / entry["file"])
    cam = scene.cameras[0]
    a = render(scene, cam, 160, 120, device, "raster")
    b = render(scene, cam, 160, 120, device, "raycast")
    s = _compare(scene, a, b)
    assert s["pixels"] > 5000
    assert s["background_agree"] >= 0.999
    assert s["depth_agree"] >= 0.999
    assert s["normal_agree"] >= 0.995
    assert s["same_triangle"] >= 0.99
    assert s["same_hit_bits"] == 1.0


@pytest.mark.parametrize("path", ["raster", "raycast"])
@pytest.mark.parametrize("ball", [(24, 48), (6, 12)])  # 2884 triangles: bands of clusters; 724: bands of rows
def test_one_and_two_threads_give_identical_gbuffers(device: str, render, path: str, ball: tuple[int, int]) -> None:
    scene, cam = _analytic_scene(*ball)
    one = render(scene, cam, 96, 72, device, path, threads=1)
    two = render(scene, cam, 96, 72, device, path, threads=2)
    for name in GBUFFER_FIELDS:
        np.testing.assert_array_equal(one.channel_numpy(name), two.channel_numpy(name), err_msg=name)
