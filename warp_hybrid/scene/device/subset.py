"""A device scene as the rasterizer sees part of it: the triangles of some materials hidden.

``hide_materials`` gives ``scene`` itself when no triangle's material is hidden, else a
shallow copy whose ``gpu`` index array collapses each hidden triangle to its first
corner (zero area: it covers no pixel centre), every triangle id unchanged, so hit
records, the surface pass and ``triangle_material`` read the same tables.  Only the
rasterizer honours it: the BVH (``scene.mesh``) still holds every triangle.  Users:
the shadow maps (emitters and glass cast nothing) and the raster layer's second
visibility layer behind alpha-blended surfaces (``lighting/alpha_layer.py``).  They
pass their last view back (``previous``): a scene update never changes a device scene's
triangles or their materials (``DeviceScene.update``), so where the same materials are
hidden the collapsed index array is reused and only the struct is made again (it
follows the arrays an update replaced), with no copy of the indices per update.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np
import warp as wp

from ...core.scene_gpu import SceneGPU
from ..model import Material
from .upload import DeviceScene


def hide_materials(
    scene: DeviceScene, hidden: Callable[[Material], bool], previous: DeviceScene | None = None
) -> DeviceScene:
    """``scene`` with the triangles whose material satisfies ``hidden`` collapsed (module
    docstring); ``scene`` itself when there are none.  ``previous``: the caller's last
    view, of this device scene or another (its indices are reused where they fit)."""
    materials = scene.scene.materials
    skip = np.array([hidden(m) for m in materials] or [False], dtype=bool)
    if (
        previous is not None
        and previous.view_of is scene
        and previous.hidden_materials is not None
        and np.array_equal(previous.hidden_materials, skip)
    ):
        view_indices = previous.indices
    else:
        tri_skip = skip[np.asarray(scene.scene.triangle_material, dtype=np.int64)]
        if not tri_skip.any():
            return scene
        indices = np.array(scene.scene.indices, dtype=np.int32)
        indices[tri_skip] = indices[tri_skip][:, :1]
        view_indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=scene.device)
    view = copy.copy(scene)
    view.view_of = scene
    view.hidden_materials = skip
    view.indices = view_indices
    view.gpu = SceneGPU()
    for name in SceneGPU.vars:
        setattr(view.gpu, name, getattr(scene.gpu, name))
    view.gpu.indices = view.indices
    return view
