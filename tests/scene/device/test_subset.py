"""``subset.hide_materials``: a view that collapses the hidden materials' triangles, reused
across scene updates without copying the indices again, and always drawn as a fresh
renderer draws it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from warp_hybrid import Renderer, RenderSettings, open_scene_source
from warp_hybrid.focus import FocusWindow
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.subset import hide_materials

CORNELL = Path(__file__).resolve().parents[3] / "scenes" / "cornell_glass.usda"


def _blended_scene():
    """The glass box with its glass as alpha coverage (a layer behind it is drawn)."""
    scene = open_scene_source(CORNELL).scene_at(None)
    materials = [dataclasses.replace(m, alpha_blended=m.is_transmissive) for m in scene.materials]
    return dataclasses.replace(scene, materials=materials)


def _collapsed(view: DeviceScene) -> np.ndarray:
    """Per triangle: whether the view collapsed it to its first corner."""
    idx = view.indices.numpy().reshape(-1, 3)
    return (idx[:, 0] == idx[:, 1]) & (idx[:, 1] == idx[:, 2])


def test_a_view_is_reused_across_updates_and_rebuilt_for_another_mask(device: str) -> None:
    scene = _blended_scene()
    ds = DeviceScene(scene, device)
    blended = np.array([m.is_blended for m in scene.materials])[scene.triangle_material]
    first = hide_materials(ds, lambda m: m.is_blended)
    np.testing.assert_array_equal(_collapsed(first), blended)
    ds.update(dataclasses.replace(scene, points=scene.points + np.float32(0.01), time=1.0))
    second = hide_materials(ds, lambda m: m.is_blended, first)
    assert second.indices is first.indices  # the same triangles hidden: no copy
    assert second.gpu.points.ptr == ds.gpu.points.ptr and second.gpu.indices.ptr == first.indices.ptr
    emissive = np.array([m.is_emissive for m in scene.materials])[scene.triangle_material]
    other = hide_materials(ds, lambda m: m.is_emissive, second)
    assert other.indices is not first.indices
    np.testing.assert_array_equal(_collapsed(other), emissive)
    # another device scene's view is never reused
    fresh = DeviceScene(scene, device)
    assert hide_materials(fresh, lambda m: m.is_blended, first).indices is not first.indices
    assert hide_materials(ds, lambda m: False, first) is ds  # nothing hidden: the scene itself


def test_the_layer_behind_follows_moving_points_as_a_fresh_renderer_draws_it(device: str) -> None:
    scene = _blended_scene()
    cam = scene.cameras[0]
    moved = dataclasses.replace(scene, points=scene.points + np.float32(0.05), time=1.0)
    settings = RenderSettings(width=48, height=36, device=device, mode="raster", shadow_maps=True, exposure_ev=0.0)
    with Renderer(scene, settings) as r:
        r.render(cam)
        r.update_scene(moved)
        after = r.render(cam, FocusWindow(gaze=(0.5, 0.5), fraction=0.2))
    with Renderer(moved, settings) as fresh:
        expected = fresh.render(cam)
    np.testing.assert_array_equal(after.image, expected.image)
    np.testing.assert_array_equal(after.color, expected.color)
