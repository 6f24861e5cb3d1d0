"""Small stages and a CLI runner for the bad-input tests (issue 14)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

from warp_hybrid.cli import main

#: A 32x24 image: every kernel these tests run is compiled once and cached.
SIZE = ["--size", "32x24"]


@dataclass
class Run:
    """One CLI run: exit status and the stderr lines (Warp's own start-up notes left out)."""

    code: int
    err: list[str]
    out: str


def run_cli(capsys: pytest.CaptureFixture, args: Sequence[str]) -> Run:
    """``main(args)`` in this process, with what it printed."""
    capsys.readouterr()
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip() and not line.startswith("Warp ")]
    return Run(code, lines, captured.out)


def quad_stage(
    path: Path,
    *,
    size: float = 1.0,
    offset: float = 0.0,
    faces: bool = True,
    light: bool = True,
    camera: dict | None = None,
    camera_scale: float | None = None,
) -> Path:
    """A stage at ``path``: a quad /World/Quad of half-size ``size`` around ``offset`` on
    every axis, a camera /World/Cam ``3 size`` in front of it (``camera`` overrides its
    attributes: focalLength, horizontalAperture, clippingRange), a distant light."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/World")
    mesh = UsdGeom.Mesh.Define(stage, "/World/Quad")
    o, s = offset, size
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    mesh.CreatePointsAttr([Gf.Vec3f(o + a * s, o + b * s, o) for a, b in corners])
    mesh.CreateFaceVertexCountsAttr([4] if faces else [])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3] if faces else [])
    mesh.CreateSubdivisionSchemeAttr("none")
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(o, o, o + 3.0 * s))
    if camera_scale is not None:
        cam.AddScaleOp().Set(Gf.Vec3f(camera_scale, camera_scale, camera_scale))
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01 * s, 100.0 * s))
    for name, value in (camera or {}).items():
        cam.GetPrim().GetAttribute(name).Set(value)
    if light:
        UsdLux.DistantLight.Define(stage, "/World/Sun")
    stage.Save()
    return path


def files_under(folder: Path) -> list[str]:
    """Every file below ``folder`` (relative paths, sorted), temporary ones included."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())
