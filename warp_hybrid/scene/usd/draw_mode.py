"""``model:drawMode`` (``UsdGeom.ModelAPI``): a model drawn as a stand-in for its subtree.

Where a draw mode applies follows pxr (UsdImaging): the prim has ``GeomModelAPI``
applied; its draw mode, resolved by ``UsdGeom.ModelAPI.ComputeModelDrawMode`` (which
reads ``model:drawMode`` on models only, i.e. prims of a kind in a valid model
hierarchy such as component, assembly, group; ``inherited``, the fallback, takes the
nearest model ancestor's mode; none at all is ``default``), is not ``default``; and
``model:applyDrawMode`` is true, or unauthored on a prim of kind ``component``
(``Usd.ModelAPI.IsKind``, which checks the model hierarchy too).
Nothing of such a prim's subtree is drawn (meshes, instancers, lights; cameras still
count); instead, by its mode:

* ``bounds``: a closed box (``implicit.box_mesh``, 12 triangles) over the subtree's bound
  in the model's own space (``UsdGeom.BBoxCache.ComputeUntransformedBound`` with the
  purposes default, proxy and render and ``extentsHint``, as usdview computes it),
  placed by the model's transform, its albedo ``model:drawModeColor`` (fallback 0.18
  grey).  usdview draws the box's edges, so it is warned about.
* ``cards``: the same box; cards (``model:cardGeometry``) and their textures
  (``model:cardTexture*``) are not supported (warned).
* ``origin``: nothing; usdview draws the model's axes as three lines, which cannot be
  drawn here (warned).

A mode that is none of these is warned about and the model drawn as its full geometry.
The box is read again at every time code when anything in the subtree (the model
included) may vary over time.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pxr import Kind, Usd, UsdGeom

from .gprims import empty_mesh
from .implicit import box_mesh
from .meshes import LocalMesh
from .validate import Diagnostics

_BOX_MODES = (UsdGeom.Tokens.bounds, UsdGeom.Tokens.cards)
_BOUND_PURPOSES = [UsdGeom.Tokens.default_, UsdGeom.Tokens.proxy, UsdGeom.Tokens.render]
_WARNINGS = {
    UsdGeom.Tokens.bounds: "model:drawMode bounds: drawn as a solid box of its bounds in model:drawModeColor "
    "(usdview draws the box's edges)",
    UsdGeom.Tokens.cards: "model:drawMode cards: drawn as a solid box of its bounds in model:drawModeColor "
    "(cards and their textures model:cardTexture* are not supported)",
    UsdGeom.Tokens.origin: "model:drawMode origin: nothing of it is drawn "
    "(usdview draws its axes as three lines; lines are not supported)",
}


@dataclass(frozen=True)
class StandIn:
    """What stands in for a model's subtree: its draw ``mode`` and ``model:drawModeColor``."""

    mode: str
    color: tuple[float, float, float]

    @property
    def draws_box(self) -> bool:
        """True when the model is drawn as the box of its bounds (bounds, cards)."""
        return self.mode in _BOX_MODES


def _applies(prim: Usd.Prim, model: UsdGeom.ModelAPI) -> bool:
    apply = model.GetModelApplyDrawModeAttr()
    if apply.HasAuthoredValue():
        return bool(apply.Get())
    return Usd.ModelAPI(prim).IsKind(Kind.Tokens.component)


def stand_in(prim: Usd.Prim, time: Usd.TimeCode, diag: Diagnostics) -> StandIn | None:
    """The stand-in that replaces ``prim``'s subtree, None when no draw mode applies to
    it (see the module docs); how it is drawn is warned once per prim."""
    if not prim.HasAPI(UsdGeom.ModelAPI):
        return None
    model = UsdGeom.ModelAPI(prim)
    mode = str(model.ComputeModelDrawMode())
    if mode == UsdGeom.Tokens.default_ or not _applies(prim, model):
        return None
    name = str(prim.GetPath())
    if mode not in _WARNINGS:
        diag.warn(f"model:drawMode {mode!r} is not a USD draw mode; drawn as its full geometry", name)
        return None
    diag.warn(_WARNINGS[mode], name)
    color = model.GetModelDrawModeColorAttr().Get(time)
    return StandIn(mode, tuple(float(c) for c in color))


def _subtree_varies(prim: Usd.Prim) -> bool:
    subtree = Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate))
    return any(a.ValueMightBeTimeVarying() for p in subtree for a in p.GetAuthoredAttributes())


def stand_in_mesh(prim: Usd.Prim, time: float, may_animate: bool = True) -> LocalMesh:
    """The box over ``prim``'s subtree at ``time`` in its own space (an empty mesh when
    nothing under it has a bound); ``may_animate=False`` skips the time-variability
    queries."""
    varies = may_animate and _subtree_varies(prim)
    cache = UsdGeom.BBoxCache(Usd.TimeCode(time), _BOUND_PURPOSES, useExtentsHint=True)
    box = cache.ComputeUntransformedBound(prim).ComputeAlignedBox()
    if box.IsEmpty():
        return replace(empty_mesh(prim), time_varying=varies)
    lo, hi = np.array(box.GetMin(), dtype=np.float64), np.array(box.GetMax(), dtype=np.float64)
    return box_mesh(str(prim.GetPath()), lo, hi, varies)
