"""Colour primvars: ``displayColor`` and the primvars a ``UsdPrimvarReader`` feeds into a
material, kept per triangle corner (``Scene.corner_colors``) instead of one mean.

* ``read_display_color``: a mesh's (possibly inherited) ``displayColor``, the one
  colour when it is constant (or all its values are equal), else "varies".
* ``primvar_input``: a ``UsdPrimvarReader_float3`` / ``_float`` / ``_float4`` node read
  as ``PrimvarInput`` (the primvar's name and the reader's ``fallback``).
* ``corner_colors``: a colour primvar at the triangle corners of a ``LocalMesh``, any
  interpolation (uniform, vertex, varying, faceVarying, constant; indexed or not);
  implicit prims (no USD faces) honour only constant values and take the mean of
  others with a warning; a mesh without the primvar gets the reader's fallback.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from .meshes import LocalMesh, corner_primvar
from .validate import Diagnostics

DISPLAY_COLOR = "displayColor"
PRIMVAR_READERS = ("UsdPrimvarReader_float3", "UsdPrimvarReader_float", "UsdPrimvarReader_float4")

Colour = tuple[float, float, float]


@dataclass(frozen=True)
class PrimvarInput:
    """A material input read from a primvar: its name and the colour used where a mesh
    does not author it (the reader's ``fallback``)."""

    varname: str
    fallback: Colour


def _colour(value: object) -> Colour:
    """A float, float3 or float4 value as an rgb colour (a float is grey)."""
    v = np.atleast_1d(np.asarray(value, dtype=np.float64))
    rgb = np.broadcast_to(v, (3,)) if v.size == 1 else v[:3]
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]))


def primvar_input(node: UsdShade.Shader, time: Usd.TimeCode) -> PrimvarInput:
    """The primvar reader ``node`` (its id in ``PRIMVAR_READERS``) as a ``PrimvarInput``;
    a missing ``fallback`` is 0 (UsdPrimvarReader's default)."""
    inp = node.GetInput("varname")
    varname = str(inp.Get(time) or "") if inp else ""
    fb = node.GetInput("fallback")
    value = fb.Get(time) if fb else None
    return PrimvarInput(varname, _colour(0.0 if value is None else value))


def _primvar(prim: Usd.Prim, name: str) -> UsdGeom.Primvar | None:
    pv = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)
    return pv if pv and pv.HasAuthoredValue() else None


def read_display_color(prim: Usd.Prim, time: Usd.TimeCode) -> tuple[Colour | None, bool]:
    """(the constant displayColor or None, whether it varies over the prim): None, False
    when it is not authored (or empty)."""
    pv = _primvar(prim, DISPLAY_COLOR)
    if pv is None:
        return None, False
    values = np.asarray(pv.ComputeFlattened(time) or [], dtype=np.float64).reshape(-1, 3)
    if not len(values):
        return None, False
    if pv.GetInterpolation() == UsdGeom.Tokens.constant or (values == values[0]).all():
        return _colour(values[0]), False
    return None, True


def corner_colors(local: LocalMesh, prim: Usd.Prim, source: PrimvarInput, time: float, diag: Diagnostics) -> np.ndarray:
    """The colour primvar ``source.varname`` of ``prim`` at the triangle corners of
    ``local`` (T, 3, 3) float32 (see the module docstring for the fallbacks)."""
    name = str(prim.GetPath())
    t = Usd.TimeCode(time)
    fallback = np.broadcast_to(np.asarray(source.fallback, dtype=np.float32), (local.triangle_count, 3, 3))
    pv = _primvar(prim, source.varname)
    if pv is None:
        diag.warn(f"primvar {source.varname!r} read by its material is not authored; using its fallback", name)
        return fallback.copy()
    if pv.GetInterpolation() == UsdGeom.Tokens.constant or not prim.IsA(UsdGeom.Mesh):
        values = np.asarray(pv.ComputeFlattened(t) or [], dtype=np.float32).reshape(-1, 3)
        if not len(values):
            return fallback.copy()
        if len(values) > 1 and pv.GetInterpolation() != UsdGeom.Tokens.constant:
            diag.warn(
                f"{source.varname} with {pv.GetInterpolation()} interpolation on a {prim.GetTypeName()} "
                "(no faces to follow); its mean is used",
                name,
            )
            values = values.mean(axis=0, keepdims=True)
        return np.broadcast_to(values[0], fallback.shape).copy()
    colours = corner_primvar(local, pv, time, 3, diag, "its fallback colour")
    return (fallback.copy() if colours is None else colours).astype(np.float32)
