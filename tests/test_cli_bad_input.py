"""Bad input, bad paths, interruptions (issue 14): each case is one ``error:`` line naming
the file, the prim and the problem, exit status 2, nothing written; or a render with
its warnings printed once."""

from __future__ import annotations

import math
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from bad_input_kit import SIZE, files_under, quad_stage, run_cli
from pxr import Gf

from warp_hybrid import Renderer, RenderSettings, open_scene_source
from warp_hybrid.errors import ArgumentTypeError, RenderSettingsError, SceneError
from warp_hybrid.memory import frame_bytes, host_bytes

ROOT = Path(__file__).resolve().parents[1]
CORNELL = ROOT / "scenes" / "cornell_glass.usda"


@pytest.fixture()
def scene(tmp_path: Path) -> Path:
    """A small lit quad with a camera."""
    return quad_stage(tmp_path / "quad.usda")


def refused(capsys, out_dir: Path, args: list, needle: str) -> str:
    """Run ``args``; assert status 2, one ``error:`` line holding ``needle``, nothing in ``out_dir``."""
    run = run_cli(capsys, args)
    assert run.code == 2, run
    assert len(run.err) == 1 and run.err[0].startswith("error: "), run.err
    assert needle in run.err[0], run.err[0]
    assert "Traceback" not in run.err[0] and "pxrInternal" not in run.err[0]
    assert files_under(out_dir) == []
    return run.err[0]


# -- output paths: checked before the scene is loaded -------------------------------------


def test_output_into_a_folder_nobody_can_write(capsys, tmp_path: Path) -> None:
    # /proc refuses new files even to root, so this holds for whoever runs the tests
    line = refused(
        capsys, tmp_path, ["render", "missing.usda", "-o", "/proc/x.png"], "/proc/x.png: cannot write in /proc"
    )
    assert "missing.usda" not in line  # checked before the scene


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_output_into_a_read_only_folder(capsys, tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        refused(capsys, tmp_path, ["render", CORNELL, "-o", ro / "x.png"], "cannot write in")
    finally:
        ro.chmod(0o755)


def test_output_naming_a_folder(capsys, tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "taken.png").mkdir(parents=True)
    refused(capsys, tmp_path, ["render", "missing.usda", "-o", out / "taken.png"], "taken.png: output path is a folder")


def test_aov_dir_naming_a_file_writes_no_png(capsys, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "afile").write_text("x")
    args = ["render", CORNELL, "-o", out / "a.png", "--aov-dir", tmp_path / "afile", *SIZE]
    refused(capsys, out, args, "afile: --aov-dir must be a folder, but it is a file")


def test_jpg_is_refused_before_the_render(capsys, tmp_path: Path) -> None:
    line = refused(
        capsys, tmp_path, ["render", "missing.usda", "-o", tmp_path / "x.jpg"], "output image must be a .png"
    )
    assert line == f"error: {tmp_path / 'x.jpg'}: output image must be a .png file"


def test_one_path_for_two_outputs(capsys, tmp_path: Path) -> None:
    same = tmp_path / "a.png"
    refused(
        capsys, tmp_path, ["render", CORNELL, "-o", same, "--stats-json", same], "given to both -o and --stats-json"
    )


def test_outputs_are_written_as_a_set(tmp_path: Path) -> None:
    from warp_hybrid.output import Outputs

    with pytest.raises(TypeError), Outputs() as out:
        out.add_png(tmp_path / "a.png", np.zeros((2, 2, 3), np.uint8))
        out.add_json(tmp_path / "s.json", {"bad": object()})
    assert files_under(tmp_path) == []  # the PNG, written first, was not kept either


# -- cameras ---------------------------------------------------------------------------------

CAMERAS = {
    "focal_zero": ({"focalLength": 0.0}, "focalLength must be a positive finite number, got 0.0"),
    "focal_negative": ({"focalLength": -50.0}, "focalLength must be a positive finite number, got -50.0"),
    "focal_nan": ({"focalLength": math.nan}, "focalLength must be a positive finite number, got nan"),
    "aperture_zero": ({"horizontalAperture": 0.0}, "horizontalAperture must be a positive finite number, got 0.0"),
    "clip_negative": (
        {"clippingRange": Gf.Vec2f(-1, 100)},
        "clippingRange must be finite with 0 < near < far, got (-1.0, 100.0)",
    ),
    "clip_inverted": (
        {"clippingRange": Gf.Vec2f(100, 1)},
        "clippingRange must be finite with 0 < near < far, got (100.0, 1.0)",
    ),
    "clip_zero": (
        {"clippingRange": Gf.Vec2f(0, 0)},
        "clippingRange must be finite with 0 < near < far, got (0.0, 0.0)",
    ),
}


@pytest.mark.parametrize("case", sorted(CAMERAS))
def test_invalid_camera_names_the_prim(capsys, tmp_path: Path, case: str) -> None:
    attrs, problem = CAMERAS[case]
    path = quad_stage(tmp_path / f"{case}.usda", camera=attrs)
    line = refused(capsys, tmp_path / "none", ["render", path, "-o", tmp_path / "none" / "x.png", *SIZE], problem)
    assert line == f"error: {path}: /World/Cam: {problem}"


def test_camera_scaled_by_zero(capsys, tmp_path: Path) -> None:
    path = quad_stage(tmp_path / "scaled.usda", camera_scale=0.0)
    refused(
        capsys,
        tmp_path / "none",
        ["render", path, "-o", tmp_path / "none" / "x.png"],
        "/World/Cam: its transform scales it by 0",
    )


def test_the_renderer_applies_the_same_camera_rule(tmp_path: Path) -> None:
    from dataclasses import replace

    scene = open_scene_source(quad_stage(tmp_path / "q.usda")).scene_at(None)
    with Renderer(scene, RenderSettings(width=32, height=24, mode="raster")) as renderer:
        with pytest.raises(
            RenderSettingsError, match=r"camera /World/Cam: focalLength must be a positive finite number, got 0"
        ):
            renderer.render(replace(scene.cameras[0], focal_length=0))
        for bad in (5, None, "cam"):
            with pytest.raises(ArgumentTypeError, match=r"camera must be a warp_hybrid.scene.model.Camera"):
                renderer.render(bad)  # type: ignore[arg-type]
        with pytest.raises(ArgumentTypeError, match=r"window must be a FocusWindow or None, got tuple"):
            renderer.render(scene.cameras[0], (0.5, 0.5))  # type: ignore[arg-type]


# -- settings ----------------------------------------------------------------------------------


@pytest.mark.parametrize("ev", ["1e6", "nan", "inf", "-65"])
def test_exposure_out_of_range(capsys, tmp_path: Path, ev: str) -> None:
    line = refused(
        capsys, tmp_path, ["render", "missing.usda", "-o", tmp_path / "x.png", f"--exposure={ev}"], "exposure"
    )
    assert line.startswith("error: exposure must be 'auto' (None) or a number of stops in [-64, 64], got ")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"width": "640"}, "RenderSettings.width must be an integer, got str '640'"),
        ({"width": 64.5}, "RenderSettings.width must be an integer, got float 64.5"),
        ({"max_depth": 2.5}, "RenderSettings.max_depth must be an integer, got float 2.5"),
        ({"exposure_ev": "1"}, "RenderSettings.exposure_ev must be a number or None, got str '1'"),
        ({"antialias": 1}, "RenderSettings.antialias must be True or False, got int 1"),
        ({"threads": True}, "RenderSettings.threads must be an integer or None, got bool True"),
        ({"mode": None}, "RenderSettings.mode must be a string, got NoneType None"),
    ],
)
def test_settings_types_name_the_field(kwargs: dict, message: str) -> None:
    with pytest.raises(ArgumentTypeError) as info:
        RenderSettings(**kwargs).validate()
    assert str(info.value) == message and isinstance(info.value, TypeError)


def test_huge_size_is_refused_with_the_estimate(capsys, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr("warp_hybrid.memory._host_available", lambda: 8 * 10**9)  # an 8 GB machine
    line = refused(
        capsys, tmp_path, ["render", CORNELL, "-o", tmp_path / "x.png", "--size", "16384x16384", "--threads", "2"], ""
    )
    lights = len(open_scene_source(CORNELL).scene_at(None).lights)
    need = frame_bytes(16384, 16384, lights, 2) + host_bytes(16384, 16384, lights)
    assert f"a 16384x16384 frame needs about {need / 1e9:.1f} GB on cpu" in line
    assert line.endswith("more than the 8.0 GB available: render a smaller image")


def test_size_negative_gets_its_own_message(capsys, tmp_path: Path) -> None:
    line = refused(capsys, tmp_path, ["render", CORNELL, "-o", tmp_path / "x.png", "--size", "-5x10"], "")
    assert line == (
        "error: warp-hybrid render: argument --size: size must be positive, got '-5x10' (see warp-hybrid render --help)"
    )


def test_time_nan_is_a_time_error(capsys, tmp_path: Path, scene: Path) -> None:
    line = refused(
        capsys,
        tmp_path / "o",
        ["render", scene, "-o", tmp_path / "o" / "x.png", "--time", "nan", "--gaze", "trace:nope.csv"],
        "argument --time: must be a finite number, got 'nan'",
    )
    assert "nope.csv" not in line
    with pytest.raises(SceneError, match=r"quad\.usda: time code nan is not a finite number"):
        open_scene_source(scene).scene_at(float("nan"))


@pytest.mark.parametrize("gaze", ["5,5", "fixed:5,5", "-0.1,0.5"])
def test_gaze_outside_the_screen_is_refused_either_way(capsys, tmp_path: Path, gaze: str) -> None:
    line = refused(
        capsys,
        tmp_path,
        ["render", "missing.usda", "-o", tmp_path / "x.png", "--gaze", gaze],
        "point must lie in [0,1]^2 (normalised, origin top-left)",
    )
    assert "missing.usda" not in line  # refused before the scene is opened


# -- scenes that render, with a warning once ------------------------------------------------


@pytest.mark.parametrize(
    "case, warnings",
    [
        ("empty", ["the stage has no UsdGeom.Camera", "no lights", "nothing to see:"]),
        ("no_faces", ["/World/Quad: the mesh has no faces", "nothing to see:"]),
        ("no_lights", ["no lights (no UsdLux light, no dome): lit as usdview does, by a headlight"]),
    ],
)
def test_empty_scenes_render_and_warn_once(capsys, tmp_path: Path, case: str, warnings: list[str]) -> None:
    path = tmp_path / f"{case}.usda"
    if case == "empty":
        from pxr import Usd

        Usd.Stage.CreateNew(str(path)).Save()
    else:
        quad_stage(path, faces=case != "no_faces", light=case != "no_lights")
    out = tmp_path / "o" / "x.png"
    run = run_cli(capsys, ["render", path, "-o", out, *SIZE])
    assert run.code == 0 and out.is_file()
    assert len(run.err) == len(warnings)
    for line, needle in zip(run.err, warnings):
        assert line.startswith(f"warning: {path}: ") and needle in line


def test_scene_warnings_are_printed_once(capsys, tmp_path: Path) -> None:
    from pxr import Usd, UsdGeom

    path = quad_stage(tmp_path / "sphere.usda")
    stage = Usd.Stage.Open(str(path))
    UsdGeom.BasisCurves.Define(stage, "/World/Hair")
    stage.Save()
    run = run_cli(capsys, ["render", path, "-o", tmp_path / "x.png", *SIZE])
    assert run.code == 0
    assert len(run.err) == 1  # the logger's line only, not the command's copy of Scene.warnings
    assert run.err[0].startswith(f"warning: {path}: /World/Hair: BasisCurves prims are not supported")


# -- coordinates -------------------------------------------------------------------------------


def test_coordinates_beyond_the_range_are_refused(capsys, tmp_path: Path) -> None:
    path = quad_stage(tmp_path / "huge.usda", size=1e10)
    refused(
        capsys,
        tmp_path / "o",
        ["render", path, "-o", tmp_path / "o" / "x.png"],
        f"{path}: /World/Quad: point 0 ([-10000000000.0, -10000000000.0, 0.0]) is beyond the "
        "representable range (|coordinate| <= 2^30 = 1.07e+09 around the camera)",
    )
    assert open_scene_source(quad_stage(tmp_path / "big.usda", size=1e8)).scene_at(None).triangle_count == 2


def test_a_scene_too_far_for_float64_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"/World/Cam: lies 1e\+15 units from the world origin, more than 2\^42"):
        open_scene_source(quad_stage(tmp_path / "far.usda", offset=1e15)).scene_at(None)
    assert open_scene_source(quad_stage(tmp_path / "near.usda", offset=1e9)).scene_at(None).origin.max() > 0


# -- messages ------------------------------------------------------------------------------


def test_pxr_namespaces_are_stripped(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "broken.usda"
    bad.write_text('#usda 1.0\ndef Mesh "M" {\n  point3f[] points = [(0,0,0), (1,0,0)\n}\n')
    line = refused(capsys, tmp_path / "o", ["render", bad, "-o", tmp_path / "o" / "x.png"], "not a readable USD file")
    assert "parse error matching Sdf_TextFileFormatParser::ListValueClose" in line


def test_convert_names_the_file_once(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1\n")
    line = refused(capsys, tmp_path / "o", ["convert", bad, tmp_path / "o" / "x.usda"], "cannot read mesh file")
    assert line.count("bad.off") == 1
    refused(capsys, tmp_path / "o", ["convert", bad, tmp_path / "o" / "x.obj"], "unsupported output extension '.obj'")


# -- gaze ----------------------------------------------------------------------------------


def test_gaze_convert_counts_bad_confidences_as_invalid(capsys, tmp_path: Path) -> None:
    trace = tmp_path / "conf.csv"
    trace.write_text("t,x,y,confidence\n0,0.5,0.5,nan\n0.1,0.5,0.5,7\n0.2,0.5,0.5,0.9\n0.3,0.5,0.5,inf\n0.4,0.5,0.5,\n")
    out = tmp_path / "new" / "c.csv"  # a missing folder is created, as for every output
    run = run_cli(capsys, ["gaze", "convert", trace, out])
    assert run.code == 0 and run.err == []
    assert run.out.strip() == (
        f"{out}: 5 samples (2 valid) over 0.400 s from simple {trace}; invalid: 3 confidence not a number in [0, 1]"
    )
    rows = out.read_text().splitlines()
    assert rows[1:] == [
        "0.000000,,,0",
        "0.100000,,,0",
        "0.200000,0.500000,0.500000,0.9000",
        "0.300000,,,0",
        "0.400000,0.500000,0.500000,1.0000",
    ]


def test_gaze_convert_checks_its_output_before_reading(capsys, tmp_path: Path) -> None:
    refused(
        capsys,
        tmp_path,
        ["gaze", "convert", tmp_path / "missing.csv", "/proc/c.csv"],
        "/proc/c.csv: cannot write in /proc",
    )


# -- files: permissions -------------------------------------------------------------------------


def test_new_outputs_follow_the_umask_and_overwrites_keep_their_mode(capsys, tmp_path: Path, scene: Path) -> None:
    png, stats = tmp_path / "a.png", tmp_path / "s.json"
    old = os.umask(0o002)
    try:
        assert run_cli(capsys, ["render", scene, "-o", png, "--stats-json", stats, *SIZE]).code == 0
        modes = [stat.S_IMODE(p.stat().st_mode) for p in (png, stats)]
        png.chmod(0o640)
        assert run_cli(capsys, ["render", scene, "-o", png, "--stats-json", stats, *SIZE]).code == 0
    finally:
        os.umask(old)
    assert modes == [0o664, 0o664]
    assert [stat.S_IMODE(p.stat().st_mode) for p in (png, stats)] == [0o640, 0o664]


# -- Ctrl-C -------------------------------------------------------------------------------------


def test_ctrl_c_prints_one_line_and_exits_130(tmp_path: Path) -> None:
    out = tmp_path / "o"
    args = ["render", CORNELL, "-o", out / "x.png", "--size", "320x240", "--mode", "full", "--spp", "256"]
    # SIGINT raises KeyboardInterrupt in the child even where this runner was started with it ignored
    launch = (
        "import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "sys.argv = ['warp-hybrid', *sys.argv[1:]]; runpy.run_module('warp_hybrid', run_name='__main__')"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", launch, *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "WARP_HYBRID_THREADS": "1"},
    )
    time.sleep(6.0)  # past the start-up, inside the 256-sample render
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("Warp ")]
    assert proc.returncode == 130
    assert lines == ["interrupted: warp-hybrid render stopped; no file is left half-written"]
    assert not out.exists() or files_under(out) == []
