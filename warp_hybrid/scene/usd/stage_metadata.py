"""Checks on stage metadata the renderer relies on: the up axis and the time rates.

* ``upAxis``: UsdGeom allows only Y and Z (``UsdGeom.GetStageUpAxis`` returns what is
  authored, even an invalid token).  X or anything else warns once and is treated as Y.
* ``timeCodesPerSecond`` / ``framesPerSecond``: pxr stores them unchecked in binary
  layers (a text layer with such a value fails to open with pxr's own parse error);
  zero, negative or non-finite rates make time codes meaningless, so they raise
  ``SceneError`` naming the file and the rule.
"""

from __future__ import annotations

import math
from dataclasses import replace

from pxr import Usd, UsdGeom

from ...errors import SceneError
from .stage import StageInfo
from .validate import Diagnostics

SUPPORTED_UP_AXES = (str(UsdGeom.Tokens.y), str(UsdGeom.Tokens.z))


def check_stage_metadata(info: StageInfo, stage: Usd.Stage, path: str, diag: Diagnostics) -> StageInfo:
    """``info`` with an unsupported up axis replaced by Y (warned); raises ``SceneError``
    for a time rate that is not a positive number."""
    # framesPerSecond first: pxr's timeCodesPerSecond falls back to it when unauthored.
    for name, value in (
        ("framesPerSecond", stage.GetFramesPerSecond()),
        ("timeCodesPerSecond", stage.GetTimeCodesPerSecond()),
    ):
        if not (math.isfinite(value) and value > 0):
            raise SceneError(
                path, f"{name} is {value:g}; it must be a positive number of time codes (frames) per second"
            )
    if info.up_axis in SUPPORTED_UP_AXES:
        return info
    kind = "X, which UsdGeom does not allow" if info.up_axis == "X" else f"{info.up_axis!r}, not a valid value"
    diag.warn(f"upAxis is {kind} (only Y or Z); treated as Y")
    return replace(info, up_axis="Y")
