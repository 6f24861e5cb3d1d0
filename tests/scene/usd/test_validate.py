"""Checks on flattened scenes and per-prim data, and the once-only warning log."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.authoring.builders import make_scene, quad
from warp_hybrid.scene.model import Material
from warp_hybrid.scene.usd.validate import Diagnostics, check_points, check_primvar, check_topology, validate_scene


def _scene():
    return make_scene(
        [quad((0, 0, 0), (1, 0, 0), (0, 1, 0), name="/A"), quad((0, 0, 1), (1, 0, 0), (0, 1, 0), name="/B")],
        [Material("m")],
        path="mem.usda",
    )


def test_valid_scene_passes():
    validate_scene(_scene())


@pytest.mark.parametrize(
    "corrupt, message",
    [
        (lambda s: s.indices.__setitem__((3, 1), 99), "triangle 3 indexes outside the 8 points"),
        (lambda s: s.points.__setitem__((5, 2), np.nan), "point 5 is not finite"),
        (lambda s: s.corner_normals.__setitem__((2, 0, 0), np.inf), "corner_normals of triangle 2"),
        (lambda s: s.corner_uvs.__setitem__((3, 2, 1), np.nan), "corner_uvs of triangle 3"),
        (lambda s: s.triangle_material.__setitem__(2, 4), "triangle 2 uses material 4 of 1"),
    ],
)
def test_corrupt_arrays_name_file_and_mesh(corrupt, message):
    scene = _scene()
    corrupt(scene)
    with pytest.raises(SceneError, match=message) as err:
        validate_scene(scene)
    assert str(err.value).startswith("mem.usda: /B: ")


def test_wrong_dtype_or_shape():
    scene = _scene()
    scene.points = scene.points.astype(np.float64)
    with pytest.raises(SceneError, match="points has shape"):
        validate_scene(scene)


def test_check_points_and_topology():
    check_points(np.zeros((3, 3), np.float32), "f.usda", "/M")
    with pytest.raises(SceneError, match="f.usda: /M: point 2 is not finite"):
        check_points(np.array([[0, 0, 0], [1, 0, 0], [0, np.inf, 0]], np.float32), "f.usda", "/M")
    check_topology(np.array([3, 4]), np.arange(7) % 5, 5, "f.usda", "/M")
    with pytest.raises(SceneError, match="outside the 5 points"):
        check_topology(np.array([3]), np.array([0, 1, 5]), 5, "f.usda", "/M")
    with pytest.raises(SceneError, match="sum to 7"):
        check_topology(np.array([3, 4]), np.arange(6), 5, "f.usda", "/M")


def test_check_primvar_counts():
    diag = Diagnostics("f.usda")
    # 2 faces, 4 points, 6 face-vertices
    assert check_primvar("st", "faceVarying", 6, 2, 4, 6, diag, "/M", "zeros")
    assert check_primvar("st", "uniform", 2, 2, 4, 6, diag, "/M", "zeros")
    assert check_primvar("st", "constant", 1, 2, 4, 6, diag, "/M", "zeros")
    assert not check_primvar("st", "vertex", 6, 2, 4, 6, diag, "/M", "zeros")
    assert not check_primvar("st", "sideways", 6, 2, 4, 6, diag, "/M", "zeros")
    assert diag.messages == [
        "/M: st has 6 values but vertex interpolation needs 4; using zeros",
        "/M: st has unknown interpolation 'sideways'; using zeros",
    ]


def test_diagnostics_report_each_warning_once(caplog):
    diag = Diagnostics("f.usda")
    with caplog.at_level(logging.WARNING, logger="warp_hybrid.scene"):
        for _ in range(3):
            diag.warn("Points prims are not supported", "/World/P")
        diag.warn("other", key="k")
        diag.warn("other, same key", key="k")
    assert diag.messages == ["/World/P: Points prims are not supported", "other"]
    assert [r.getMessage() for r in caplog.records] == [
        "f.usda: /World/P: Points prims are not supported",
        "f.usda: other",
    ]
