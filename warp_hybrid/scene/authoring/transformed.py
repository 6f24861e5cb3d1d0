"""A whole stage moved or rescaled: a new root layer that references a scene under one
root transform, cameras, lights and time samples included.

``write_transformed_stage(source, out, translate, scale)`` writes ``out`` with a default
prim ``/Root`` (``xformOp:translate`` then ``xformOp:scale``, so a point ``p`` of the
source lands at ``scale * p + translate``) whose child ``World`` references the source's
default prim.  The stage metadata (upAxis, metersPerUnit, the time range and rate) is the
source's, so the result is the same scene in a georeferenced or rescaled frame: what a
renderer must draw identically up to float rounding (the invariance tests, and
``scripts/hard_cases_table.py``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom

from ...errors import SceneError

ROOT_PATH = "/Root"


def write_transformed_stage(
    source: str | os.PathLike,
    out: str | os.PathLike,
    translate: Sequence[float] = (0.0, 0.0, 0.0),
    scale: float = 1.0,
) -> Path:
    """Write ``out`` (.usda/.usdc): ``source``'s default prim referenced under ``/Root``,
    which maps a source point ``p`` to ``scale * p + translate`` (see the module
    docstring).  Raises ``SceneError`` when ``source`` cannot be opened or has no
    default prim, or ``scale`` is not a positive finite number."""
    src = os.fspath(source)
    if not (float(scale) > 0.0 and float(scale) < float("inf")):
        raise SceneError(src, f"a stage scale must be a positive finite number, got {scale!r}")
    stage_in = Usd.Stage.Open(src)
    if stage_in is None:
        raise SceneError(src, "pxr could not open this file as a USD stage")
    default = stage_in.GetDefaultPrim()
    if not default:
        raise SceneError(src, "the stage has no default prim to reference")
    out_path = Path(out)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.GetStageUpAxis(stage_in))
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.GetStageMetersPerUnit(stage_in))
    if stage_in.HasAuthoredTimeCodeRange():
        stage.SetStartTimeCode(stage_in.GetStartTimeCode())
        stage.SetEndTimeCode(stage_in.GetEndTimeCode())
    stage.SetTimeCodesPerSecond(stage_in.GetTimeCodesPerSecond())
    root = UsdGeom.Xform.Define(stage, ROOT_PATH)
    root.AddTranslateOp().Set(Gf.Vec3d(*(float(v) for v in translate)))
    root.AddScaleOp().Set(Gf.Vec3d(float(scale), float(scale), float(scale)))
    stage.SetDefaultPrim(root.GetPrim())
    world = stage.DefinePrim(f"{ROOT_PATH}/{default.GetName()}")
    ref = os.path.relpath(os.path.abspath(src), os.path.abspath(out_path.parent))
    world.GetReferences().AddReference(Sdf.Reference(Path(ref).as_posix()))
    out_path.parent.mkdir(parents=True, exist_ok=True)
    stage.GetRootLayer().Export(str(out_path))
    return out_path
