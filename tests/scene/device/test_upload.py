"""``upload``: the device scene's arrays as the CPU's row loops read them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from warp_hybrid import open_scene_source
from warp_hybrid.scene.device import DeviceScene

CORNELL = Path(__file__).resolve().parents[3] / "scenes" / "cornell_glass.usda"


def test_the_points_have_a_spare_zero_point_after_the_last_through_updates(device: str) -> None:
    # (the surface loop loads a corner's three floats as four: the last point's fourth is
    # the spare's first)
    scene = open_scene_source(CORNELL).scene_at(None)
    ds = DeviceScene(scene, device)
    n = len(scene.points)
    backing = ds.points._ref  # the allocation the points are a view of
    assert ds.points.shape == (n,) and backing.shape == (n + 1,) and ds.points.ptr == backing.ptr
    np.testing.assert_array_equal(backing.numpy()[:n], scene.points.astype(np.float32))
    np.testing.assert_array_equal(backing.numpy()[n], 0.0)
    moved = dataclasses.replace(scene, points=scene.points + np.float32(0.25), time=1.0)
    ds.update(moved)
    assert ds.points._ref is backing
    np.testing.assert_array_equal(backing.numpy()[:n], moved.points.astype(np.float32))
    np.testing.assert_array_equal(backing.numpy()[n], 0.0)
