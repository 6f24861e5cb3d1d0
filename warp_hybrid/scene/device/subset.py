"""A device scene as the rasterizer sees part of it: the triangles of some materials hidden.

``hide_materials`` gives ``scene`` itself when no triangle's material is hidden, else a
shallow copy whose ``gpu`` index array collapses each hidden triangle to its first
corner (zero area: it covers no pixel centre), every triangle id unchanged, so hit
records, the surface pass and ``triangle_material`` read the same tables.  Only the
rasterizer honours it: the BVH (``scene.mesh``) still holds every triangle.  Users:
the shadow maps (emitters and glass cast nothing) and the raster layer's second
visibility layer behind alpha-blended surfaces (``lighting/alpha_layer.py``).
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np
import warp as wp

from ...core.scene_gpu import SceneGPU
from ..model import Material
from .upload import DeviceScene


def hide_materials(scene: DeviceScene, hidden: Callable[[Material], bool]) -> DeviceScene:
    """``scene`` with the triangles whose material satisfies ``hidden`` collapsed (module
    docstring); ``scene`` itself when there are none."""
    materials = scene.scene.materials
    skip = np.array([hidden(m) for m in materials] or [False], dtype=bool)
    tri_skip = skip[np.asarray(scene.scene.triangle_material, dtype=np.int64)]
    if not tri_skip.any():
        return scene
    indices = np.array(scene.scene.indices, dtype=np.int32)
    indices[tri_skip] = indices[tri_skip][:, :1]
    view = copy.copy(scene)
    view.indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=scene.device)
    view.gpu = SceneGPU()
    for name in SceneGPU.vars:
        setattr(view.gpu, name, getattr(scene.gpu, name))
    view.gpu.indices = view.indices
    return view
