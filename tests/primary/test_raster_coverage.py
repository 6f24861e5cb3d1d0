"""Fill rule and watertightness of the raster path: exact pixel-centre coverage,
shared edges without cracks or double coverage, closed meshes without holes; empty
scenes and reused G-buffers."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import BACKGROUND, CHANNELS, GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer, RayCaster
from warp_hybrid.scene.authoring.builders import MeshInput, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Camera, Material
from warp_hybrid.timing import StageTimer

W, H = 64, 48


def _camera() -> Camera:
    """At the origin looking down -Z with tan(half hfov) = 1: a point (X, Y, -1)
    lands on screen (32 + 32 X, 24 - 32 Y)."""
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.05, 1.0e4)


def _screen_quad(x0: float, x1: float, y0: float, y1: float, material: int = 0) -> MeshInput:
    """A quad at depth 1 covering screen x in [x0, x1], y in [y0, y1] (y down)."""
    left, right = (x0 - 32.0) / 32.0, (x1 - 32.0) / 32.0
    top, bottom = (24.0 - y0) / 32.0, (24.0 - y1) / 32.0
    return quad((left, bottom, -1.0), (right - left, 0.0, 0.0), (0.0, top - bottom, 0.0), material)


def test_quad_covers_exactly_the_pixel_centres_inside(device: str, render, overdraw) -> None:
    """Edges through pixel centres: the top and left edges own them, the bottom and right do not."""
    scene = make_scene([_screen_quad(10.5, 20.5, 5.5, 15.5)], [Material("m")])
    expected = np.zeros((H, W), bool)
    expected[5:15, 10:20] = True
    gb = render(scene, _camera(), W, H, device)
    np.testing.assert_array_equal(gb.triangle_id.numpy() >= 0, expected)
    np.testing.assert_array_equal(overdraw(scene, _camera(), W, H, device), expected.astype(np.int64))


def test_quad_between_pixel_centres(device: str, render) -> None:
    scene = make_scene([_screen_quad(3.2, 9.9, 40.1, 44.7)], [Material("m")])
    expected = np.zeros((H, W), bool)
    expected[40:45, 3:10] = True
    np.testing.assert_array_equal(render(scene, _camera(), W, H, device).triangle_id.numpy() >= 0, expected)


def test_adjacent_quads_share_an_edge_without_gap_or_overlap(device: str, render, overdraw) -> None:
    scene = make_scene([_screen_quad(10.5, 20.5, 5.5, 15.5), _screen_quad(20.5, 30.5, 5.5, 15.5)], [Material("m")])
    counts = overdraw(scene, _camera(), W, H, device)
    expected = np.zeros((H, W), np.int64)
    expected[5:15, 10:30] = 1
    np.testing.assert_array_equal(counts, expected)
    tri = render(scene, _camera(), W, H, device).triangle_id.numpy()
    assert set(np.unique(tri[5:15, 20])) <= {2, 3}  # the shared column belongs to the right quad (its left edge)


def test_tessellated_plane_covers_each_pixel_once(device: str, overdraw) -> None:
    """A jittered grid (arbitrary shared edges, vertices on pixel centres included):
    every pixel inside the outline is covered by exactly one triangle."""
    rng = np.random.default_rng(7)
    n = 13
    g = np.linspace(-0.7, 0.7, n)
    xs, ys = np.meshgrid(g, g * 0.8)
    jitter = rng.uniform(-0.04, 0.04, (n, n, 2))
    jitter[[0, -1], :, :] = 0.0
    jitter[:, [0, -1], :] = 0.0
    pts = np.stack([xs + jitter[..., 0], ys + jitter[..., 1], -np.ones_like(xs)], axis=-1).reshape(-1, 3)
    pts[::7, :2] = (np.round(pts[::7, :2] * 32.0 - 0.5) + 0.5) / 32.0  # some vertices exactly on pixel centres
    idx = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            idx += [(a, b, e), (a, e, d)] if (r + c) % 2 else [(a, b, d), (b, e, d)]
    scene = make_scene([MeshInput(pts.astype(np.float32), np.asarray(idx, np.int32))], [Material("m")])
    counts = overdraw(scene, _camera(), W, H, device)
    assert counts.max() == 1
    covered = counts == 1
    np.testing.assert_array_equal(ndimage.binary_fill_holes(covered), covered)
    assert covered[6:42, 12:52].all()


def test_closed_sphere_is_watertight(device: str, render, overdraw) -> None:
    """Seen from outside, a closed convex mesh covers each pixel inside its outline
    exactly twice (front and back), never once or three times, with no hole."""
    scene = make_scene([uv_sphere((0.1, 0.05, -3.0), 1.0, rings=10, segments=20)], [Material("m")])
    counts = overdraw(scene, _camera(), W, H, device)
    assert set(np.unique(counts)) == {0, 2}
    inside = counts == 2
    np.testing.assert_array_equal(ndimage.binary_fill_holes(inside), inside)
    assert inside.sum() > 200
    np.testing.assert_array_equal(render(scene, _camera(), W, H, device).triangle_id.numpy() >= 0, inside)


def test_empty_scene_is_all_background(device: str, render) -> None:
    scene = make_scene([], [Material("m")])
    for path in ("raster", "raycast"):
        gb = render(scene, _camera(), W, H, device, path)
        assert (gb.triangle_id.numpy() == -1).all() and np.isinf(gb.depth.numpy()).all()


def test_every_pixel_is_rewritten_each_frame(device: str) -> None:
    """A reused G-buffer keeps nothing from the previous frame (nothing clears it: the
    primary kernels write the background record, every channel, where nothing is hit)."""
    ds = DeviceScene(make_scene([uv_sphere((0.0, 0.0, -3.0), 1.0, rings=8, segments=16)], [Material("m")]), device)
    away = Camera("/away", np.diag([-1.0, 1.0, -1.0, 1.0]), 50.0, 100.0, 75.0, 0.05, 1.0e4)
    with Launcher(device, threads=2) as launcher:
        for renderer in (Rasterizer(launcher), RayCaster(launcher)):
            gb = GBuffer(W, H, device)
            renderer.render(ds, make_camera_gpu(_camera(), W, H), gb, StageTimer())
            assert (gb.triangle_id.numpy() >= 0).any()
            renderer.render(ds, make_camera_gpu(away, W, H), gb, StageTimer())
            for c in CHANNELS:
                assert (gb.channel_numpy(c.name) == BACKGROUND[c.name]).all(), c.name


def test_overdraw_and_hits_are_the_same_on_any_thread_count(device: str, render, overdraw) -> None:
    """The row bands of a small scene (every thread covering its own rows of one key
    slice) and the cluster bands of a larger one (a slice per thread) count the same
    fragments and find the same hits as one thread."""
    small = make_scene([uv_sphere((0.1, 0.05, -3.0), 1.0, rings=10, segments=20)], [Material("m")])
    # 64 spheres of 800 triangles: over 16 clusters of 64 triangles a thread, so cluster bands.
    large = make_scene(
        [
            uv_sphere((-1.4 + 0.4 * (k % 8), -1.0 + 0.3 * (k // 8), -3.0 - 0.01 * k), 0.3, rings=20, segments=20)
            for k in range(64)
        ],
        [Material("m")],
    )
    assert large.triangle_count >= 3 * 16 * 64
    for scene in (small, large):
        counts = overdraw(scene, _camera(), W, H, device)
        tri = render(scene, _camera(), W, H, device).triangle_id.numpy()
        assert counts.max() >= 2 and (tri >= 0).sum() > 200
        for threads in (2, 3):
            np.testing.assert_array_equal(overdraw(scene, _camera(), W, H, device, threads=threads), counts)
            np.testing.assert_array_equal(
                render(scene, _camera(), W, H, device, threads=threads).triangle_id.numpy(), tri
            )


def test_a_band_of_rows_leaves_the_other_rows_alone(device: str) -> None:
    """``find_hits`` over some rows writes those rows' hit records only, on one or two
    threads: the rest keep what the last full frame wrote."""
    ds = DeviceScene(make_scene([uv_sphere((0.1, 0.05, -3.0), 1.0, rings=10, segments=20)], [Material("m")]), device)
    cam = make_camera_gpu(_camera(), W, H)
    for threads in (1, 2):
        with Launcher(device, threads=threads) as launcher:
            rasterizer = Rasterizer(launcher)
            full = GBuffer(W, H, device)
            rasterizer.find_hits(ds, cam, full, StageTimer())
            expected = full.triangle_id.numpy().reshape(H, W)
            part = GBuffer(W, H, device)
            part.triangle_id.fill_(-7)
            rasterizer.find_hits(ds, cam, part, StageTimer(), rows=(10, 30))
            got = part.triangle_id.numpy().reshape(H, W)
            np.testing.assert_array_equal(got[10:30], expected[10:30])
            assert (got[:10] == -7).all() and (got[30:] == -7).all()
            assert (expected[10:30] >= 0).any()
