"""Shadow-ray geometry: the scene's triangles split into two BVHs.

A shadow ray only needs to know whether an *opaque* surface blocks it, which an
any-hit query answers (it stops at the first triangle found); only the few surfaces
that let light through (transmissive and alpha cut-out materials) need the ordered
closest-hit walk that multiplies their tints.  Emitters (an area light's own
geometry, which every ray toward that light's centre ends on) cast no shadow at all,
so they are in neither BVH.  So the tracer keeps

* ``opaque``: a ``wp.Mesh`` of the other triangles, queried with
  ``wp.mesh_query_ray_anyhit``;
* ``special``: a ``wp.Mesh`` of the transmissive and cut-out triangles, walked with
  ``wp.mesh_query_ray``; ``special_faces`` maps its faces back to scene triangle ids
  (materials, textures, normals).

When every triangle is opaque and none emits, the scene's own BVH serves as
``opaque`` and nothing is built.  Both meshes share the ``DeviceScene``'s points
array, so after an animated update they are refitted, not rebuilt (with ``wide``, only
their 4-wide copies: the queries never read Warp's trees then).

With ``wide`` (the CPU's default, ``TraceSettings.wide_bvh``) each of the two also has
its 4-wide copy (``scene/device/wide_bvh.WideBVH``: the same tree and answers, 2-3x
faster queries), and ``scene_wide`` is the scene's own (``DeviceScene.wide_bvh``, the
path's closest hits), which that variant of the tracer queries instead
(``TraceVariant.wide_bvh``); a refit copies the refitted boxes into them.  Without it
(CUDA) they are empty and never read.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..scene.device import DeviceScene
from ..scene.device.wide_bvh import WideBVH, WideBVHGPU
from ..scene.model import Material


@wp.struct
class OccluderGPU:
    """The shadow BVHs (below): opaque triangles (any-hit) and the transmissive and
    cut-out ones (ordered walk; emitters are in neither), ``special_faces`` mapping the
    latter's faces to scene triangle ids; an id of 0 means empty.  ``*_wide``: the 4-wide
    copies of the two and of the scene's BVH (``scene_wide``; CPU only, else empty)."""

    opaque: wp.uint64
    special: wp.uint64
    special_faces: wp.array(dtype=wp.int32)
    opaque_wide: WideBVHGPU
    special_wide: WideBVHGPU
    scene_wide: WideBVHGPU


def lets_light_through(m: Material) -> bool:
    """Shadow rays must look at this material's surfaces one by one (it is transmissive
    or alpha-tested)."""
    return m.is_transmissive or m.is_cutout


class Occluders:
    """The two shadow BVHs of one ``DeviceScene`` (see the module docstring)."""

    def __init__(self, scene: DeviceScene, wide: bool = False) -> None:
        """Split ``scene``'s triangles by material and build the BVHs (once), and with
        ``wide`` (CPU only) their 4-wide copies and the scene's."""
        self.scene = scene
        self.wide = wide
        self._geometry_version = scene.geometry_version
        self._materials_version = scene.materials_version
        mats = scene.scene.materials
        tri_mat = np.asarray(scene.scene.triangle_material, dtype=np.int64)
        casting = np.array([m.casts_shadow for m in mats] or [True], dtype=bool)[tri_mat]
        special = casting & np.array([lets_light_through(m) for m in mats] or [False], dtype=bool)[tri_mat]
        opaque_tris = casting & ~special
        self.special_count = int(special.sum())
        self.opaque_count = int(opaque_tris.sum())
        indices = np.asarray(scene.scene.indices, dtype=np.int32).reshape(-1, 3)
        dev = scene.device
        self._meshes: list[wp.Mesh] = []
        g = OccluderGPU()
        scene_wide = scene.query_bvh(wide)
        if opaque_tris.all():
            g.opaque = wp.uint64(scene.mesh.id if scene.mesh is not None else 0)
            opaque_wide = scene_wide
        else:
            opaque = self._mesh(indices[opaque_tris])
            g.opaque = wp.uint64(opaque.id if opaque is not None else 0)
            opaque_wide = self._wide(opaque, self.opaque_count)
        special_mesh = self._mesh(indices[special])
        g.special = wp.uint64(special_mesh.id if special_mesh is not None else 0)
        special_wide = self._wide(special_mesh, self.special_count)
        faces = np.flatnonzero(special).astype(np.int32) if self.special_count else np.zeros(1, dtype=np.int32)
        # the scene's own copy is refitted by its update, with its mesh
        self._wides = [w for w in (opaque_wide, special_wide) if w.node_count and w is not scene_wide]
        self.special_faces = wp.array(faces, dtype=wp.int32, device=dev)
        g.special_faces = self.special_faces
        g.scene_wide, g.opaque_wide, g.special_wide = scene_wide.gpu, opaque_wide.gpu, special_wide.gpu
        self.gpu = g

    def _mesh(self, tris: np.ndarray) -> wp.Mesh | None:
        """A BVH over ``tris`` (T, 3) sharing the scene's points; None when empty."""
        if len(tris) == 0:
            return None
        idx = wp.array(np.ascontiguousarray(tris.reshape(-1)), dtype=wp.int32, device=self.scene.device)
        mesh = wp.Mesh(points=self.scene.points, indices=idx)
        self._meshes.append(mesh)
        return mesh

    def _wide(self, mesh: wp.Mesh | None, triangles: int) -> WideBVH:
        """The 4-wide copy of ``mesh``; an empty one without ``wide`` or without a mesh."""
        return WideBVH(mesh if self.wide else None, triangles, self.scene.device)

    def matches(self, scene: DeviceScene) -> bool:
        """Whether these BVHs split ``scene``'s triangles as its materials do now (a
        material update can move triangles between the two meshes)."""
        return scene is self.scene and self._materials_version == scene.materials_version

    def refresh(self) -> None:
        """Refit what the queries read if the scene's points moved since the last call
        (``DeviceScene.geometry_version``): with ``wide`` the 4-wide copies (only where the
        points moved when that was one update, ``DeviceScene.moved_points``; else whole),
        without it the two BVHs and the scene's own (``DeviceScene.warp_bvh``)."""
        version = self.scene.geometry_version
        if version != self._geometry_version:
            if self.wide:  # the queries walk the copies alone: Warp's trees are never read
                moved = self.scene.moved_points if version == self._geometry_version + 1 else None
                for wide in self._wides:
                    wide.refit(moved)
            else:
                for mesh in self._meshes:
                    mesh.refit()
                self.scene.warp_bvh()  # the scene's own tree serves the path's hits (and may be ``opaque``)
            self._geometry_version = version
