"""Shadow-ray geometry: the scene's triangles split into two BVHs.

A shadow ray only needs to know whether an *opaque* surface blocks it, which an
any-hit query answers (it stops at the first triangle found); only the few surfaces
that let light through or emit it (transmissive, alpha cut-out and emissive
materials) need the ordered closest-hit walk that multiplies their tints.  So the
tracer keeps

* ``opaque``: a ``wp.Mesh`` of every other triangle, queried with
  ``wp.mesh_query_ray_anyhit``;
* ``special``: a ``wp.Mesh`` of the transmissive, cut-out and emissive triangles,
  walked with ``wp.mesh_query_ray``; ``special_faces`` maps its faces back to scene
  triangle ids (materials, textures, normals).

When every triangle is opaque the scene's own BVH serves as ``opaque`` and nothing
is built.  Both meshes share the ``DeviceScene``'s points array, so after an animated
update they are refitted, not rebuilt.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..scene.device import DeviceScene
from ..scene.model import Material


@wp.struct
class OccluderGPU:
    """The shadow BVHs (below): opaque triangles (any-hit) and the
    transmissive/cut-out/emissive ones (ordered walk), ``special_faces`` mapping the
    latter's faces to scene triangle ids; an id of 0 means empty."""

    opaque: wp.uint64
    special: wp.uint64
    special_faces: wp.array(dtype=wp.int32)


def lets_light_through(m: Material) -> bool:
    """Shadow rays must look at this material's surfaces one by one (it is transmissive,
    alpha-tested or emissive; emitters do not cast shadows)."""
    return m.is_transmissive or m.is_cutout or m.is_emissive


class Occluders:
    """The two shadow BVHs of one ``DeviceScene`` (see the module docstring)."""

    def __init__(self, scene: DeviceScene) -> None:
        """Split ``scene``'s triangles by material and build the BVHs (once)."""
        self.scene = scene
        self._geometry_version = scene.geometry_version
        self._materials_version = scene.materials_version
        special_mat = np.array([lets_light_through(m) for m in scene.scene.materials] or [False], dtype=bool)
        tri_mat = np.asarray(scene.scene.triangle_material, dtype=np.int64)
        special = special_mat[tri_mat] if len(tri_mat) else np.zeros(0, dtype=bool)
        self.special_count = int(special.sum())
        indices = np.asarray(scene.scene.indices, dtype=np.int32)
        dev = scene.device
        self._meshes: list[wp.Mesh] = []
        g = OccluderGPU()
        if self.special_count == 0:
            g.opaque = wp.uint64(scene.mesh.id if scene.mesh is not None else 0)
            g.special = wp.uint64(0)
            faces = np.zeros(1, dtype=np.int32)
        else:
            g.opaque = wp.uint64(self._mesh(indices[~special]))
            g.special = wp.uint64(self._mesh(indices[special]))
            faces = np.flatnonzero(special).astype(np.int32)
        self.special_faces = wp.array(faces, dtype=wp.int32, device=dev)
        g.special_faces = self.special_faces
        self.gpu = g

    def _mesh(self, tris: np.ndarray) -> int:
        """A BVH over ``tris`` (T, 3) sharing the scene's points; id 0 when empty."""
        if len(tris) == 0:
            return 0
        idx = wp.array(np.ascontiguousarray(tris.reshape(-1)), dtype=wp.int32, device=self.scene.device)
        mesh = wp.Mesh(points=self.scene.points, indices=idx)
        self._meshes.append(mesh)
        return int(mesh.id)

    def matches(self, scene: DeviceScene) -> bool:
        """Whether these BVHs split ``scene``'s triangles as its materials do now (a
        material update can move triangles between the two meshes)."""
        return scene is self.scene and self._materials_version == scene.materials_version

    def refresh(self) -> None:
        """Refit the BVHs if the scene's points moved since the
        last call (``DeviceScene.geometry_version``)."""
        if self.scene.geometry_version != self._geometry_version:
            for mesh in self._meshes:
                mesh.refit()
            self._geometry_version = self.scene.geometry_version
