"""UsdSkel skinning through pxr: meshes bound to a Skeleton (``SkelBindingAPI``) are
drawn with pxr's skinned points at each time code, not in their rest pose.

``Skinner.binding`` resolves a mesh's binding with ``UsdSkel.Cache`` (populated per
``SkelRoot``, instance proxies included): its ``SkinningQuery`` and the bound
skeleton's ``SkeletonQuery`` (with its animation source).  ``Skinner.local_points``
skins the mesh's points at a time code with ``SkeletonQuery.ComputeSkinningTransforms``
and ``SkinningQuery.ComputeSkinnedPoints`` (linear blend or dual quaternion, as the mesh
authors ``skel:skinningMethod``; ``skel:geomBindTransform`` applied by pxr).  Those
points are in skeleton space and UsdSkel ignores the mesh's own transform, so they are
taken into world space by the skeleton's local-to-world transform and back into the
mesh's local space by the inverse of the mesh's, where the loader places every mesh.

A binding ``varies`` when its points may change over time: the animation's joint
transforms, the skeleton's, the mesh's or their ancestors' transforms, or the mesh's
binding attributes (``skel:*``, ``primvars:skel:*``) are time-varying.  Blend shapes are
not applied (a warning); a mesh bound without joint influences is drawn as authored.  A
binding pxr cannot resolve or skin is reported naming the prim and the mesh is drawn in
its rest pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdSkel, Vt

from .validate import Diagnostics

NOT_APPLIED = "skinning (SkelBindingAPI) is not applied"


@dataclass
class Skinning:
    """A mesh's resolved binding: ``skeleton`` is the bound Skeleton prim (an instance
    proxy under an instance, where the query's prim is the prototype's); ``varies``
    tells whether its skinned points may change over time."""

    prim: Usd.Prim
    skinning: UsdSkel.SkinningQuery
    skel_query: UsdSkel.SkeletonQuery
    skeleton: Usd.Prim
    varies: bool


def _transform_may_vary(prim: Usd.Prim) -> bool:
    """Whether ``prim``'s local-to-world transform may vary (its own or an ancestor's
    transform, up to a ``resetXformStack``)."""
    while prim and prim.IsA(UsdGeom.Xformable):
        xf = UsdGeom.Xformable(prim)
        if xf.TransformMightBeTimeVarying():
            return True
        if xf.GetResetXformStack():
            return False
        prim = prim.GetParent()
    return False


def _binding_attrs_vary(prim: Usd.Prim) -> bool:
    return any(
        a.ValueMightBeTimeVarying()
        for a in prim.GetAuthoredAttributes()
        if a.GetName().startswith(("skel:", "primvars:skel:"))
    )


def _matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


class Skinner:
    """Resolves and evaluates the skinning of one stage's meshes (one per scene source)."""

    def __init__(self, diag: Diagnostics) -> None:
        """Warnings go to ``diag``."""
        self.diag = diag
        self._cache = UsdSkel.Cache()
        self._populated: set[Sdf.Path] = set()

    def binding(self, prim: Usd.Prim, may_animate: bool) -> Skinning | None:
        """The skinning of the mesh ``prim`` (it applies ``SkelBindingAPI``), or None
        when it is drawn as authored: no joint influences, or (warned, naming the prim)
        a binding that cannot be resolved.  ``may_animate=False``: nothing varies."""
        name = str(prim.GetPath())
        root = UsdSkel.Root.Find(prim)
        if not root:
            self.diag.warn(f"{NOT_APPLIED}: the mesh is not under a SkelRoot; rendered in its rest pose", name)
            return None
        if root.GetPath() not in self._populated:
            self._cache.Populate(root, Usd.TraverseInstanceProxies())
            self._populated.add(root.GetPath())
        query = self._cache.GetSkinningQuery(prim)
        skeleton = UsdSkel.BindingAPI(prim).GetInheritedSkeleton()
        if not query or not skeleton:
            self.diag.warn(f"{NOT_APPLIED}: no Skeleton is bound (skel:skeleton); rendered in its rest pose", name)
            return None
        if query.HasBlendShapes():
            self.diag.warn("blend shapes (skel:blendShapes) are not applied; only the joints skin the mesh", name)
        if not query.HasJointInfluences():
            return None
        skel_query = self._cache.GetSkelQuery(skeleton)
        if not skel_query:
            self.diag.warn(
                f"{NOT_APPLIED}: its Skeleton {skeleton.GetPath()} is not valid; rendered in its rest pose", name
            )
            return None
        varies = may_animate and (
            bool(skel_query.GetAnimQuery() and skel_query.GetAnimQuery().JointTransformsMightBeTimeVarying())
            or any(a.ValueMightBeTimeVarying() for a in skeleton.GetPrim().GetAuthoredAttributes())
            or _transform_may_vary(skeleton.GetPrim())
            or _transform_may_vary(prim)
            or _binding_attrs_vary(prim)
        )
        return Skinning(prim, query, skel_query, skeleton.GetPrim(), bool(varies))

    def local_points(self, skin: Skinning, time: float) -> np.ndarray | None:
        """The mesh's skinned points (N, 3) at ``time`` in its local space, or None
        (warned, naming the prim) when pxr cannot skin them."""
        name = str(skin.prim.GetPath())
        tc = Usd.TimeCode(time)
        authored = UsdGeom.Mesh(skin.prim).GetPointsAttr().Get(tc)
        points = Vt.Vec3fArray(authored if authored is not None else [])
        xforms = skin.skel_query.ComputeSkinningTransforms(tc)
        if xforms is None or not skin.skinning.ComputeSkinnedPoints(xforms, points, tc):
            self.diag.warn(
                f"{NOT_APPLIED}: UsdSkel could not skin its {len(points)} points (see pxr's message: joint "
                "influences or transforms that do not fit); rendered in its rest pose",
                name,
            )
            return None
        skel_to_world = _matrix(UsdGeom.Xformable(skin.skeleton).ComputeLocalToWorldTransform(tc))
        mesh_to_world = _matrix(UsdGeom.Xformable(skin.prim).ComputeLocalToWorldTransform(tc))
        if abs(np.linalg.det(mesh_to_world[:3, :3])) < 1e-300:
            self.diag.warn(f"{NOT_APPLIED}: its local-to-world transform is singular; rendered in its rest pose", name)
            return None
        to_local = skel_to_world @ np.linalg.inv(mesh_to_world)
        skel_points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return (skel_points @ to_local[:3, :3] + to_local[3, :3]).astype(np.float32)
