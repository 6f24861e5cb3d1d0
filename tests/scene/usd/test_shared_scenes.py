"""Every scene in the shared folder loads with the figures its manifest lists."""

from __future__ import annotations

import json

import numpy as np
import pytest

from warp_hybrid.scene.usd.loader import UsdSceneSource

_KIND_NAMES = {"distant": "DistantLight", "sphere": "SphereLight", "rect": "RectLight", "disk": "DiskLight"}


def _manifest(shared_scenes):
    return json.loads((shared_scenes / "manifest.json").read_text())["scenes"]


def test_every_shared_scene_loads_with_manifest_counts(shared_scenes):
    for entry in _manifest(shared_scenes):
        source = UsdSceneSource(shared_scenes / entry["file"])
        scene = source.scene_at()
        name = entry["name"]
        assert scene.triangle_count == entry["triangles"], name
        if "meshes" in entry:
            assert len(scene.meshes) == entry["meshes"], name
        if "materials" in entry:
            assert len(scene.materials) == entry["materials"], name
        if "textures" in entry:
            assert len(scene.images) == entry["textures"], name
        if "lights" in entry:
            kinds = sorted(
                [_KIND_NAMES[li.kind.name.lower()] for li in scene.lights]
                + (["DomeLight"] if scene.environment is not None else [])
            )
            assert kinds == sorted(entry["lights"]), name
        if "cameras" in entry:
            assert [c.name for c in scene.cameras] == entry["cameras"], name
        if "metersPerUnit" in entry:
            assert scene.meters_per_unit == pytest.approx(entry["metersPerUnit"]), name
        if entry.get("timeCodes"):
            assert list(source.time_range) == entry["timeCodes"], name
        assert not scene.warnings, (name, scene.warnings)


def test_animated_shared_scenes_keep_topology_and_move_points(shared_scenes):
    animated = [e for e in _manifest(shared_scenes) if e.get("animated")]
    assert animated
    for entry in animated:
        source = UsdSceneSource(shared_scenes / entry["file"])
        start, end = source.time_range
        a = source.scene_at(start)
        b = source.scene_at(start + 0.25 * (end - start))
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_array_equal(a.triangle_material, b.triangle_material)
        moved = np.abs(a.points - b.points).max(axis=1) > 1e-6
        assert moved.any(), entry["name"]
        animated_points = np.zeros(len(a.points), dtype=bool)
        for r in a.meshes:
            if r.animated:
                animated_points[r.first_point : r.first_point + r.point_count] = True
        assert not (moved & ~animated_points).any(), entry["name"]  # only animated meshes move
