"""Open a USD stage with clear errors, and read its stage-level metadata.

pxr composes sublayers, references and payloads; composition problems it can work
around (a missing sublayer or reference) become warnings, a file that is missing or
is not USD becomes a ``SceneError`` naming the file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from pxr import Tf, Usd, UsdGeom

from ...errors import SceneError
from .pxr_text import strip_namespaces, tf_message
from .validate import Diagnostics

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


@dataclass(frozen=True)
class StageInfo:
    """Stage metadata: units, up axis and the authored time range.

    ``time_range`` is ``(startTimeCode, endTimeCode)`` when the stage authors one,
    else None; ``default_time`` is the time code used when the caller gives none
    (the start of the range, or 0).
    """

    meters_per_unit: float
    up_axis: str
    time_range: tuple[float, float] | None
    time_codes_per_second: float
    default_time: float

    def seconds(self, time_code: float) -> float:
        """Seconds from the start of the time range (or time code 0) to ``time_code``."""
        return (time_code - self.default_time) / self.time_codes_per_second

    def time_code(self, seconds: float) -> float:
        """The time code ``seconds`` after the start of the time range (or time code 0)."""
        return self.default_time + seconds * self.time_codes_per_second


def open_stage(path: str | os.PathLike, diag: Diagnostics | None = None) -> Usd.Stage:
    """Open ``path`` with pxr (everything loaded, all composition done by pxr).

    Raises ``SceneError`` when the file is missing, unreadable or not USD.  Composition
    errors pxr can skip (missing sublayers/references) are reported to ``diag``.
    """
    p = os.fspath(path)
    if not os.path.exists(p):
        raise SceneError(p, "file not found")
    if not os.path.isfile(p):
        raise SceneError(p, "not a file")
    try:
        stage = Usd.Stage.Open(p, Usd.Stage.LoadAll)
    except Tf.ErrorException as exc:
        raise SceneError(p, f"not a readable USD file ({tf_message(exc)})") from None
    if stage is None:
        raise SceneError(p, "pxr could not open this file as a USD stage")
    if diag is not None:
        report_composition_errors(stage, diag)
    return stage


def report_composition_errors(stage: Usd.Stage, diag: Diagnostics) -> None:
    """Turn pxr's composition errors (missing sublayers, references, payloads) into
    warnings: pxr skips the broken arc, so the scene still loads without it."""
    for err in stage.GetCompositionErrors():
        diag.warn(f"composition error: {strip_namespaces(str(err))}")


def read_stage_info(stage: Usd.Stage) -> StageInfo:
    """metersPerUnit, upAxis, and the authored time range of ``stage``."""
    has_range = stage.HasAuthoredTimeCodeRange()
    start, end = float(stage.GetStartTimeCode()), float(stage.GetEndTimeCode())
    return StageInfo(
        meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(stage)),
        up_axis=str(UsdGeom.GetStageUpAxis(stage)),
        time_range=(start, end) if has_range else None,
        time_codes_per_second=float(stage.GetTimeCodesPerSecond()),
        default_time=start if has_range else 0.0,
    )
