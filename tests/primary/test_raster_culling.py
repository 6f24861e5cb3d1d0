"""Cluster culling in the raster pass: a cluster is skipped only where every point of
its box lies beyond one frustum plane, so culling changes which triangles are looked
at, never the image."""

from __future__ import annotations

import numpy as np
import warp as wp

from warp_hybrid.core.camera import CameraGPU, make_camera_gpu
from warp_hybrid.primary import clipping, kernels
from warp_hybrid.primary.clipping import ProjectedPoints
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Camera, Material


@wp.kernel
def _culled(cam: CameraGPU, boxes: wp.array2d(dtype=wp.vec3), out: wp.array(dtype=wp.int32)):
    i = wp.tid()
    out[i] = wp.where(kernels._box_culled(cam, boxes[i, 0], boxes[i, 1]), 1, 0)


def test_outcodes_are_the_trivial_rejects_tests_point_by_point(device: str) -> None:
    """Each bit of a point's outcode is one float32 test of the triangle's trivial rejects
    (z < near, z > far, x > tan_x z, -x > tan_x z, y > tan_y z, -y > tan_y z; z >= near),
    so the corners sharing a bit is the rejects' conjunction over them: points on both
    sides of every plane, on the planes, and NaN (which is neither behind nor in front).
    Through the points pass (``camera_points_kernel``) of a camera at the origin looking
    down -Z, whose camera space is the world's with z negated, exactly."""
    camera = Camera("/identity", np.eye(4), focal_length=20.0, horizontal_aperture=36.0, near=0.5, far=20.0)
    cam = make_camera_gpu(camera, 64, 48)
    rng = np.random.default_rng(3)
    c = rng.uniform(-30.0, 30.0, (5000, 3)).astype(np.float32)
    tx, ty = np.float32(cam.tan_x), np.float32(cam.tan_y)
    c[:50, 2] = np.float32(cam.near)  # on the near plane
    c[50:100, 0] = tx * c[50:100, 2]  # on the right plane
    c[100:110] = np.nan
    pts = ProjectedPoints()
    pts.camera = wp.zeros(len(c), dtype=wp.vec3, device=device)
    pts.outcodes = wp.zeros(len(c), dtype=wp.int32, device=device)
    pts.screen = wp.zeros(len(c), dtype=wp.vec3, device=device)
    world = wp.array(c * np.float32([1.0, 1.0, -1.0]), dtype=wp.vec3, device=device)
    wp.launch(kernels.camera_points_kernel, dim=len(c), inputs=[world, cam, pts, 0, len(c), 1], device=device)
    np.testing.assert_array_equal(pts.camera.numpy(), c)  # (the camera space the bits are of)
    out = pts.outcodes
    x, y, z = c[:, 0], c[:, 1], c[:, 2]
    with np.errstate(invalid="ignore"):
        tests = [z < np.float32(cam.near), z > np.float32(cam.far), x > tx * z, -x > tx * z, y > ty * z, -y > ty * z]
        tests.append(z >= np.float32(cam.near))
    expected = sum(t.astype(np.int32) << k for k, t in enumerate(tests))
    np.testing.assert_array_equal(out.numpy(), expected)
    assert int(clipping.OUTSIDE_BITS) == 63 and int(clipping.IN_FRONT_BIT) == 64
    assert (expected[100:110] == 0).all()  # NaN: no bit
    assert all(((expected >> k) & 1).any() and not ((expected >> k) & 1).all() for k in range(7))


def _camera_space(camera, points: np.ndarray) -> np.ndarray:
    m = np.asarray(camera.cam_to_world, np.float64)
    axes = np.stack([m[:3, 0], m[:3, 1], -m[:3, 2]])  # right, up, forward (unit here)
    return (points - m[:3, 3]) @ axes.T


def test_a_culled_box_has_no_point_inside_the_frustum(device: str) -> None:
    """Random boxes around a camera's frustum: every culled box's corners and interior
    samples are outside the frustum (float64), and a box holding a point well inside
    the frustum is never culled."""
    camera = look_at_camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), hfov_deg=60.0, near=0.5, far=20.0)
    cam = make_camera_gpu(camera, 64, 48)
    rng = np.random.default_rng(7)
    lower = rng.uniform(-30.0, 30.0, (4000, 3))
    upper = lower + rng.uniform(0.0, 6.0, (4000, 3)) ** 2
    boxes = wp.array(np.stack([lower, upper], axis=1).astype(np.float32), dtype=wp.vec3, device=device)
    out = wp.zeros(len(lower), dtype=wp.int32, device=device)
    wp.launch(_culled, dim=len(lower), inputs=[cam, boxes, out], device=device)
    culled = out.numpy().astype(bool)
    assert 0.2 < culled.mean() < 0.95  # both outcomes are exercised

    t = rng.uniform(0.0, 1.0, (len(lower), 64, 3))
    t[:, :8] = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)], np.float64)  # the corners
    samples = lower[:, None, :] + t * (upper - lower)[:, None, :]
    c = _camera_space(camera, samples.reshape(-1, 3)).reshape(samples.shape)
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    tx, ty = camera.tan_half_fov_x, camera.tan_half_fov_y(64, 48)
    inside = (z >= camera.near) & (z <= camera.far) & (np.abs(x) <= tx * z) & (np.abs(y) <= ty * z)
    assert not inside[culled].any()
    deep = (
        (z >= 1.1 * camera.near) & (z <= 0.9 * camera.far) & (np.abs(x) <= 0.9 * tx * z) & (np.abs(y) <= 0.9 * ty * z)
    )
    assert not (culled & deep.any(axis=1)).any()


def test_culling_changes_no_pixel_of_a_field_of_small_triangles(device: str, render) -> None:
    """A floor of 40 x 40 quads (3200 triangles, 50 clusters) far larger than the view,
    seen from a grazing camera: many clusters are culled, and the raster G-buffer still
    agrees with the ray cast exactly on every pixel away from the quads' shared edges
    (same triangle id and depth)."""
    tiles = []
    for i in range(40):
        for j in range(40):
            origin = (-40.0 + 2.0 * i, 0.0, -40.0 + 2.0 * j)
            tiles.append(quad(origin, (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), 0, f"/tile_{i}_{j}"))
    camera = look_at_camera((3.0, 1.5, 6.0), (0.0, 0.0, 0.0), hfov_deg=40.0, near=0.1, far=25.0)
    scene = make_scene(tiles, [Material("floor")], cameras=[camera])
    raster = render(scene, camera, 96, 72, device, "raster", threads=2)
    cast = render(scene, camera, 96, 72, device, "raycast")
    tri_r, tri_c = raster.triangle_id.numpy(), cast.triangle_id.numpy()
    hit = tri_c >= 0
    assert 0.5 < hit.mean() < 1.0  # the floor ends at the far plane: both hits and misses
    # pixels whose centres sit within a hair of a shared edge may pick either side
    same = tri_r == tri_c
    assert same.mean() > 0.995
    depth_r, depth_c = raster.depth.numpy()[same & hit], cast.depth.numpy()[same & hit]
    np.testing.assert_allclose(depth_r, depth_c, rtol=1e-5)

    # and many clusters (strips of 32 quads) were indeed skipped
    corners = np.asarray(scene.points, np.float64)[np.asarray(scene.indices).reshape(-1, 3)]
    size = kernels.CLUSTER_TRIANGLES
    clusters = [corners[k : k + size].reshape(-1, 3) for k in range(0, len(corners), size)]
    boxes = np.stack([[c.min(axis=0), c.max(axis=0)] for c in clusters]).astype(np.float32)
    out = wp.zeros(len(boxes), dtype=wp.int32, device=device)
    wp.launch(
        _culled,
        dim=len(boxes),
        inputs=[make_camera_gpu(camera, 96, 72), wp.array(boxes, dtype=wp.vec3, device=device), out],
        device=device,
    )
    assert out.numpy().mean() > 0.3


def test_cluster_boxes_follow_moving_points(device: str) -> None:
    """A quad that starts behind the camera (its cluster culled) and is then moved in
    front of it is drawn by the same rasterizer: the boxes are recomputed when the
    points move."""
    import dataclasses

    from warp_hybrid.core.gbuffer import GBuffer
    from warp_hybrid.parallel import Launcher
    from warp_hybrid.primary import Rasterizer
    from warp_hybrid.scene.device import DeviceScene
    from warp_hybrid.timing import StageTimer

    camera = look_at_camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), hfov_deg=60.0)
    scene = make_scene([quad((-1.0, -1.0, 8.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0))], [Material("m")], cameras=[camera])
    ds = DeviceScene(scene, device)
    gbuffer = GBuffer(16, 12, device)
    cam = make_camera_gpu(camera, 16, 12)
    hits = []
    with Launcher(device, threads=1) as launcher:
        raster = Rasterizer(launcher)
        for z in (8.0, 0.0):
            points = np.asarray(scene.points).copy()
            points[:, 2] = z
            ds.update(dataclasses.replace(scene, points=points))
            raster.render(ds, cam, gbuffer, StageTimer())
            hits.append(float((gbuffer.triangle_id.numpy() >= 0).mean()))
    assert hits[0] == 0.0 and hits[1] > 0.1


def test_a_new_scene_gets_its_own_boxes(device: str) -> None:
    """One rasterizer drawing a scene, then another scene of as many triangles (same
    geometry version) in another place: the boxes are the new scene's, not the first's
    (nothing keyed on an object id that a freed scene's successor may reuse)."""
    import gc

    from warp_hybrid.core.gbuffer import GBuffer
    from warp_hybrid.parallel import Launcher
    from warp_hybrid.primary import Rasterizer
    from warp_hybrid.scene.device import DeviceScene
    from warp_hybrid.timing import StageTimer

    camera = look_at_camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), hfov_deg=60.0)
    cam = make_camera_gpu(camera, 16, 12)
    gbuffer = GBuffer(16, 12, device)
    hits = []
    with Launcher(device, threads=1) as launcher:
        raster = Rasterizer(launcher)
        for z in (8.0, 0.0):  # behind the camera, then in front of it
            scene = make_scene([quad((-1.0, -1.0, z), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0))], [Material("m")])
            ds = DeviceScene(scene, device)
            raster.render(ds, cam, gbuffer, StageTimer())
            hits.append(float((gbuffer.triangle_id.numpy() >= 0).mean()))
            del ds
            gc.collect()
    assert hits[0] == 0.0 and hits[1] > 0.1
