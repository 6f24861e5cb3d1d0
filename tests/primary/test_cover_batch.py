"""The coverage pass's native batch (``primary/cover_batch.py``) against the Warp path it
stands for on the CPU: the same key buffer bit for bit, depth keys and fragment counts,
over triangles that take every branch (tiny and wide ones, degenerate ones, ones outside
the frustum, crossing the near plane or leaving the guard band, cut out), and in a band
of rows."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.camera import CameraGPU, make_camera_gpu
from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.primary.clipping import ProjectedPoints
from warp_hybrid.primary.cover_batch import BATCH_TRIANGLES, cover_batch
from warp_hybrid.primary.coverage import EMPTY_KEY, MODE_COUNT, MODE_DEPTH, RasterTarget
from warp_hybrid.primary.kernels import _cover_triangle
from warp_hybrid.scene.authoring.builders import MeshInput, make_scene
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Camera, Material

wp.set_module_options({"enable_backward": False})

W, H = 96, 64


@wp.kernel
def warp_path_kernel(scene: SceneGPU, cam: CameraGPU, pts: ProjectedPoints, target: RasterTarget, triangles: int):
    for tri in range(triangles):
        _cover_triangle(scene, cam, pts, target, tri)


@wp.kernel
def batch_path_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    target: RasterTarget,
    triangles: int,
    left_out: wp.array(dtype=wp.uint64),
):
    for batch in range((triangles + BATCH_TRIANGLES - 1) // BATCH_TRIANGLES):
        first = batch * BATCH_TRIANGLES
        stop = wp.min(first + BATCH_TRIANGLES, triangles)
        left = cover_batch(scene, cam, pts, target, first, stop)
        left_out[batch] = left
        for tri in range(first, stop):
            if ((left >> wp.uint64(tri - first)) & wp.uint64(1)) != wp.uint64(0):
                _cover_triangle(scene, cam, pts, target, tri)


def _scene():
    """Triangles at every kind of place in front of a camera at the origin looking down
    -Z (near 0.05): small ones, wide ones, zero-area ones, ones beside or behind the
    view, ones crossing the near plane, ones far outside the guard band, and a share of
    them with a cut-out material; edges through pixel centres; small ones at the image's
    right and bottom borders; triangles across the far plane, small ones too."""
    rng = np.random.default_rng(3)
    tris = []
    for _ in range(260):  # small, in view, at random depths
        c = np.array([rng.uniform(-1.2, 1.2), rng.uniform(-0.8, 0.8), -1.0]) * rng.uniform(0.5, 4.0)
        tris.append(c + rng.normal(0.0, 0.04, (3, 3)))
    for _ in range(30):  # wide (the rows' narrowed spans)
        c = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.4, 0.4), -2.0])
        tris.append(c + rng.normal(0.0, 0.6, (3, 3)) * [1.0, 1.0, 0.2])
    for _ in range(10):  # zero area: three points on a line
        a, d = rng.uniform(-1.0, 1.0, 3) * [1, 1, 0] + [0, 0, -2], rng.normal(0.0, 0.3, 3)
        tris.append(np.stack([a, a + d, a + 2.5 * d]))
    for _ in range(30):  # beside, above or behind the view
        c = np.array([rng.choice([-9.0, 9.0]), rng.uniform(-1, 1), rng.choice([-2.0, 3.0])])
        tris.append(c + rng.normal(0.0, 0.3, (3, 3)))
    for _ in range(15):  # crossing the near plane
        tris.append(np.array([[rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), z] for z in (0.2, -0.02, -1.5)]))
    for _ in range(10):  # far outside the guard band at a grazing depth
        tris.append(np.array([[-1e5, -0.1, -0.06], [1e5, -0.1, -0.06], [0.0, 0.3, -2.0]]))
    for _ in range(60):  # corners on pixel centres at depth 1 (screen x = 48 + 48 X, y = 32 - 48 Y):
        # edges through pixel centres, where the fill rule decides
        i, j = rng.integers(2, W - 12), rng.integers(2, H - 12)
        corners = [(i, j), (i + rng.integers(1, 10), j + rng.integers(0, 10)), (i + rng.integers(0, 10), j + 9)]
        tris.append(np.array([[(x + 0.5 - 48.0) / 48.0, (32.0 - y - 0.5) / 48.0, -1.0] for x, y in corners]))
    for _ in range(15):  # straddling the far plane (1e4)
        c = np.array([rng.uniform(-4e3, 4e3), rng.uniform(-2e3, 2e3), -1e4])
        tris.append(c + rng.normal(0.0, 2e3, (3, 3)))
    for _ in range(40):  # small, at the right edge and the bottom rows (a narrow box's tile meets the border)
        i = W - rng.uniform(0.2, 4.0) if rng.random() < 0.5 else rng.uniform(2.0, W - 2.0)
        j = H - rng.uniform(0.2, 4.0) if i < W - 4.0 else rng.uniform(2.0, H - 2.0)
        c = np.array([(i - 48.0) / 48.0, (32.0 - j) / 48.0, -1.0])
        tris.append(c + rng.normal(0.0, 0.03, (3, 3)) * [1.0, 1.0, 0.0])
    for _ in range(60):  # small at the far plane (a pixel is about 200 there): before, behind and across it
        c = np.array([rng.uniform(-6e3, 6e3), rng.uniform(-4e3, 4e3), -rng.uniform(0.995e4, 1.005e4)])
        tris.append(c + rng.normal(0.0, 150.0, (3, 3)))
    rng.shuffle(tris)
    points = np.concatenate(tris).astype(np.float32)
    indices = np.arange(len(points), dtype=np.int32).reshape(-1, 3)
    solid, cut = Material("solid"), Material("cut", opacity=0.4, opacity_threshold=0.5)
    half = len(indices) // 2
    meshes = [MeshInput(points, indices[:half], material=0), MeshInput(points, indices[half:], material=1)]
    scene = make_scene(meshes, [solid, cut])
    camera = Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.05, 1.0e4)
    return scene, camera


@pytest.mark.parametrize("mode", [MODE_DEPTH, MODE_COUNT])
@pytest.mark.parametrize("rows", [(0, H), (17, 41)])
@pytest.mark.parametrize("sample", [(0.5, 0.5), (0.125, 0.875)])
def test_the_batch_gives_the_warp_path_keys(mode, rows, sample):
    device = "cpu"
    scene, camera = _scene()
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(camera, W, H, sample=sample)
    with Launcher(device, threads=1) as launcher:
        raster = Rasterizer(launcher)
        raster.overdraw(ds, cam)  # (projects the points)
        pts = raster.projected_points
    triangles = ds.scene.triangle_count
    keys = {}
    for name in ("warp", "batch"):
        target = RasterTarget()
        target.keys = wp.full((1, H, W), EMPTY_KEY if mode == MODE_DEPTH else wp.uint64(0), dtype=wp.uint64)
        target.slot = 0
        target.mode = mode
        target.row_begin, target.row_end = rows
        left = wp.zeros(-(-triangles // BATCH_TRIANGLES), dtype=wp.uint64)
        if name == "warp":
            wp.launch(warp_path_kernel, dim=1, inputs=[ds.gpu, cam, pts, target, triangles], device=device)
        else:
            wp.launch(batch_path_kernel, dim=1, inputs=[ds.gpu, cam, pts, target, triangles, left], device=device)
            bits = np.unpackbits(left.numpy().view(np.uint8)).sum()
            # the batch rasterized most triangles itself and left some to the Warp path
            assert 0 < bits < triangles // 2
        keys[name] = target.keys.numpy()
    covered = keys["warp"] != (np.uint64(EMPTY_KEY.value) if mode == MODE_DEPTH else 0)
    assert covered.mean() > 0.2
    assert not covered[0, : rows[0]].any() and not covered[0, rows[1] :].any()
    np.testing.assert_array_equal(keys["batch"], keys["warp"])
