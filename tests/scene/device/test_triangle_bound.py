"""The device scene's per-triangle error bound (``scene/device/triangle_bound.py``) against a
float32 reference in numpy: triangles from 1e-3 to 1e4 in size, near and far from the
origin, and after an update that moves the points."""

from __future__ import annotations

import dataclasses

import numpy as np

from warp_hybrid.scene.authoring.builders import MeshInput, make_scene
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Material


def _reference(points: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """max(M, 8 E) per triangle in float32: M the corners' largest |coordinate|, E an edge's."""
    p = points.astype(np.float32)[indices]  # (T, 3, 3)
    m = np.abs(p).max(axis=(1, 2))
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 2] - p[:, 1]], axis=1)
    e = np.abs(edges).max(axis=(1, 2))
    return np.maximum(m, np.float32(8.0) * e)


def test_triangle_bounds_match_the_reference_and_follow_moved_points(device):
    rng = np.random.default_rng(3)
    count = 300
    size = 10.0 ** rng.uniform(-3.0, 4.0, count)  # tiny to huge triangles ...
    centre = rng.normal(size=(count, 3)) * 10.0 ** rng.uniform(-2.0, 5.0, (count, 1))  # ... near and far
    points = (centre[:, None, :] + size[:, None, None] * rng.normal(size=(count, 3, 3))).reshape(-1, 3)
    indices = np.arange(3 * count).reshape(count, 3)
    scene = make_scene([MeshInput(points, indices)], [Material("m")])
    ds = DeviceScene(scene, device)
    want = _reference(scene.points, scene.indices)
    # the extent decides some bounds, the magnitude others
    assert 0 < np.count_nonzero(want > np.abs(scene.points.astype(np.float32)[scene.indices]).max(axis=(1, 2))) < count
    np.testing.assert_array_equal(ds.triangle_bound.numpy()[:count], want)
    np.testing.assert_array_equal(ds.gpu.triangle_bound.numpy()[:count], want)
    moved = dataclasses.replace(scene, points=scene.points * 3.0 + 1.0e3, time=1.0)
    ds.update(moved)
    np.testing.assert_array_equal(ds.gpu.triangle_bound.numpy()[:count], _reference(moved.points, moved.indices))
