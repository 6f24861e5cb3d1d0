"""UsdTransform2d: the affine map of texture coordinates between a primvar reader and a
UsdUVTexture, as the ``TextureBinding.uv_transform`` row pair kernels apply.

UsdPreviewSurface defines ``out = R(rotation) (in * scale) + translation``: scale per
axis first, then a counter-clockwise rotation by ``rotation`` degrees, then the
translation (Storm's ``UsdTransform2d`` shader).  Chained nodes compose: the node
nearest the texture is applied last.
"""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdShade

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
UV_TRANSFORM_ID = "UsdTransform2d"


def _input(node: UsdShade.Shader, name: str, time: Usd.TimeCode, default: object) -> object:
    inp = node.GetInput(name)
    value = inp.Get(time) if inp else None
    return default if value is None else value


def transform2d_matrix(node: UsdShade.Shader, time: Usd.TimeCode) -> np.ndarray:
    """The 3x3 homogeneous matrix of the UsdTransform2d ``node`` (its inputs or their
    defaults: scale (1, 1), rotation 0, translation (0, 0))."""
    sx, sy = (float(v) for v in _input(node, "scale", time, (1.0, 1.0)))
    angle = math.radians(float(_input(node, "rotation", time, 0.0)))
    tx, ty = (float(v) for v in _input(node, "translation", time, (0.0, 0.0)))
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c * sx, -s * sy, tx], [s * sx, c * sy, ty], [0.0, 0.0, 1.0]], dtype=np.float64)


def as_rows(matrix: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """The top two rows of a homogeneous 2D matrix (``TextureBinding.uv_transform``)."""
    return tuple(float(v) for v in matrix[:2].reshape(-1))  # type: ignore[return-value]
