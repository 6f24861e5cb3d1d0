"""The command line as a user runs it: render, info, convert, and clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from warp_hybrid.cli import main

ROOT = Path(__file__).resolve().parents[1]
CORNELL = ROOT / "scenes" / "cornell_glass.usda"


def test_render_writes_png_aovs_and_stats(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "img.png"
    code = main(
        [
            "render",
            str(CORNELL),
            "-o",
            str(out),
            "--size",
            "64x48",
            "--aov-dir",
            str(tmp_path / "aov"),
            "--stats-json",
            str(tmp_path / "stats.json"),
        ]
    )
    assert code == 0
    img = cv2.imread(str(out))
    assert img.shape == (48, 64, 3) and img.std() > 5  # a real picture, not a flat fill
    depth = np.load(tmp_path / "aov" / "depth.npy")
    assert depth.shape == (48, 64) and depth.dtype == np.float32 and np.isfinite(depth).mean() > 0.9
    for name in ("position", "normal", "albedo", "color"):
        assert np.load(tmp_path / "aov" / f"{name}.npy").shape == (48, 64, 3)
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["resolution"] == [64, 48] and stats["device"] == "cpu"
    assert {"raster", "resolve", "surface", "lighting", "tonemap", "aa"} <= set(stats["stages_ms"])
    assert {"load", "upload", "bvh_build"} <= set(stats["setup_ms"])
    assert "img.png" in capsys.readouterr().out


def test_info_lists_effects(capsys: pytest.CaptureFixture) -> None:
    assert main(["info", str(CORNELL), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["triangles"] == 2242
    assert {"shadows", "reflections", "refractions", "transparency"} <= set(info["effects"])


def test_convert_then_render(tmp_path: Path) -> None:
    box = trimesh.creation.box(extents=(1, 2, 3))
    src = tmp_path / "box.ply"
    box.export(src)
    dst = tmp_path / "box.usda"
    assert main(["convert", str(src), str(dst)]) == 0
    assert main(["render", str(dst), "-o", str(tmp_path / "b.png"), "--size", "32x24"]) == 0
    assert cv2.imread(str(tmp_path / "b.png")).shape == (24, 32, 3)


@pytest.mark.parametrize(
    "args, needle",
    [
        (["render", "missing.usda"], "missing.usda"),
        (["render", str(CORNELL), "--camera", "/World/Cameras/Nope"], "/World/Cameras/Nope"),
        (["render", str(CORNELL), "--device", "cuda:9"], "cuda:9"),
    ],
)
def test_errors_name_the_problem_and_write_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture, args: list[str], needle: str
) -> None:
    out = tmp_path / "never.png"
    code = main([*args, "-o", str(out), "--size", "32x24", "--stats-json", str(tmp_path / "s.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and needle in err
    assert list(tmp_path.iterdir()) == []


def test_not_usd_file_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    bad = tmp_path / "broken.usda"
    bad.write_text("this is not usd\n")
    assert main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err
    assert not (tmp_path / "x.png").exists()


def test_hybrid_gaze_from_the_shipped_trace(tmp_path: Path) -> None:
    stats_path = tmp_path / "s.json"
    code = main(
        [
            "render",
            str(CORNELL),
            "-o",
            str(tmp_path / "h.png"),
            "--size",
            "64x48",
            "--mode",
            "hybrid",
            "--gaze",
            f"trace:{ROOT / 'scenes' / 'traces' / 'demo_gaze.csv'}",
            "--window",
            "0.3",
            "--stats-json",
            str(stats_path),
        ]
    )
    assert code == 0
    stats = json.loads(stats_path.read_text())
    assert stats["mode"] == "hybrid"
    assert stats["window"]["gaze"] == pytest.approx([0.3608, 0.6618], abs=1e-3)  # the trace at t = 0
    assert stats["rays"]["traced_pixels"] == stats["window"]["pixels"] > 0
    assert stats["rays"]["shadow"] > 0 and {"trace_shadow", "trace_secondary", "compose"} <= set(stats["stages_ms"])


def test_bad_gaze_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["render", str(CORNELL), "-o", str(tmp_path / "x.png"), "--gaze", "trace:nope.csv"]) == 2
    assert "nope.csv" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_render_on_a_budget_sizes_the_window_with_the_controller(tmp_path: Path) -> None:
    stats_path = tmp_path / "s.json"
    args = ["render", str(CORNELL), "-o", str(tmp_path / "b.png"), "--size", "64x48", "--fps", "15"]
    assert main([*args, "--warm-up", "3", "--stats-json", str(stats_path)]) == 0
    budget = json.loads(stats_path.read_text())["budget"]
    assert budget["budget_ms"] == pytest.approx(1000 / 15) and budget["warm_up_frames"] == 3
    assert 0.01 <= budget["window_fraction"] <= 1.0 and budget["reason"] in {
        "warmup", "predict", "grow", "hold", "panic", "infeasible"
    }  # fmt: skip
    # the traced share counts whole pixels: at 64x48 it may exceed the planned area by up
    # to half a percent of the screen (0.0054 at worst over all fractions), whatever the timing
    assert budget["frame_ms"] > 0 and budget["traced_fraction"] <= budget["window_fraction"] + 0.006


def test_replay_needs_an_output_and_a_positive_length(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    base = ["replay", str(CORNELL), "--gaze", "fixed:0.5,0.5", "--size", "32x24"]
    assert main(base) == 2
    assert "--out" in capsys.readouterr().err
    assert main([*base, "--stats", str(tmp_path / "s.csv"), "--frames", "0"]) == 2
    assert "--frames must be >= 1" in capsys.readouterr().err
    assert main([*base, "--stats", str(tmp_path / "s.csv"), "--fps", "-3"]) == 2
    assert "--fps" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_replay_keeps_a_still_views_shadows_unless_told_not_to(tmp_path: Path) -> None:
    """A fixed window over the still Cornell box: every frame (the warm-up frame drew the
    view first) traces its primary shadows again only with ``--no-shadow-cache`` (the
    stats' ``rays_shadow``: the secondary hits' are traced either way), and the frames
    are the same either way."""
    import csv

    rows, frames = {}, {}
    for name, extra in (("kept", []), ("traced", ["--no-shadow-cache"])):
        out = tmp_path / name
        args = ["replay", str(CORNELL), "--gaze", "fixed:0.5,0.5", "--size", "48x36", "--window", "0.2"]
        args += ["--frames", "3", "--stats", str(out / "s.csv"), "--frames-dir", str(out / "png"), *extra]
        assert main(args) == 0
        with open(out / "s.csv", newline="") as f:
            rows[name] = [int(r["rays_shadow"]) for r in csv.DictReader(f)]
        frames[name] = [cv2.imread(str(p)) for p in sorted((out / "png").iterdir())]
    assert len(set(rows["traced"])) == 1 and len(set(rows["kept"])) == 1
    assert 0 < rows["kept"][0] < rows["traced"][0]
    for a, b in zip(frames["kept"], frames["traced"], strict=True):
        np.testing.assert_array_equal(a, b)


def _stage_with_a_broken_mesh_and_a_subdivided_cube(tmp_path: Path) -> Path:
    """One good subdivided cube (catmullClark authored) and one mesh whose indices run
    past its points."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "stage.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/World")
    cube = UsdGeom.Mesh.Define(stage, "/World/Cube")
    pts = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
    faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    cube.CreatePointsAttr(pts)
    cube.CreateFaceVertexCountsAttr([4] * 6)
    cube.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    cube.CreateSubdivisionSchemeAttr("catmullClark")
    broken = UsdGeom.Mesh.Define(stage, "/World/Broken")
    broken.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    broken.CreateFaceVertexCountsAttr([3])
    broken.CreateFaceVertexIndicesAttr([0, 1, 7])
    broken.CreateSubdivisionSchemeAttr("none")
    stage.GetRootLayer().Save()
    return path


def test_strict_and_subdivision_levels_reach_the_loader(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``info``: a malformed mesh is skipped by default and refused with ``--strict``;
    ``--subdivision-levels`` sets how often the cube is refined (0: its 12-triangle
    cage; each Catmull-Clark level quadruples the quads; by default, auto, as often as
    its size on the screen asks); a negative level or a word other than auto is refused."""
    path = _stage_with_a_broken_mesh_and_a_subdivided_cube(tmp_path)
    triangles = {}
    for levels in (0, 1, 2):
        assert main(["info", str(path), "--json", "--subdivision-levels", str(levels)]) == 0
        triangles[levels] = json.loads(capsys.readouterr().out)["triangles"]
    assert triangles == {0: 12, 1: 48, 2: 192}
    assert main(["info", str(path), "--json"]) == 0
    auto = json.loads(capsys.readouterr().out)["triangles"]
    # by default the level follows the screen: the framing camera fills a 640-pixel view with the cube
    assert auto == 12 * 4**4
    assert main(["info", str(path), "--json", "--subdivision-levels", "auto"]) == 0
    assert json.loads(capsys.readouterr().out)["triangles"] == auto
    assert main(["info", str(path), "--subdivision-levels", "some"]) == 2
    assert "--subdivision-levels must be 0 or more, or auto, got some" in capsys.readouterr().err
    assert main(["info", str(path), "--strict"]) == 2
    assert "/World/Broken: faceVertexIndices holds 7" in capsys.readouterr().err
    assert main(["info", str(path), "--subdivision-levels", "-1"]) == 2
    assert "--subdivision-levels must be 0 or more" in capsys.readouterr().err
