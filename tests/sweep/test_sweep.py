"""The speed-against-error sweep: configurations, the Pareto front, and the bench
command's files on a tiny scene."""

from __future__ import annotations

import csv
from pathlib import Path

import cv2
import pytest

from warp_hybrid.cli import main
from warp_hybrid.sweep.configs import Config, sweep_configs
from warp_hybrid.sweep.report import RESULT_COLUMNS, pareto_front

ROOT = Path(__file__).resolve().parents[2]


def test_pareto_front_keeps_only_undominated_points() -> None:
    points = [(10.0, 0.5), (5.0, 0.6), (20.0, 0.1), (12.0, 0.55), (5.0, 0.7), (30.0, 0.1)]
    assert pareto_front(points) == [1, 0, 2]


def test_sweep_configurations() -> None:
    configs = sweep_configs([0.1, 0.5], [0.5])
    assert configs == [
        Config("raster", 0.0),
        Config("hybrid", 0.1),
        Config("hybrid", 0.5),
        Config("hybrid_centre", 0.1),
        Config("hybrid_centre", 0.5),
        Config("full", 1.0),
        Config("full_lowres", 0.25, 0.5),
    ]
    assert [c.label for c in configs][-1] == "full at 0.5x"
    with_fovea = sweep_configs([0.1, 0.5], [0.5], fovea_spp=8)
    assert with_fovea[5:7] == [Config("hybrid_fovea", 0.1, spp=8), Config("hybrid_fovea", 0.5, spp=8)]
    assert with_fovea[5].label == "hybrid 10% x8 spp"
    with pytest.raises(ValueError, match="fractions"):
        sweep_configs([0.0])
    with pytest.raises(ValueError, match="scales"):
        sweep_configs([0.5], [1.0])


def test_bench_writes_results_table_and_plot(tmp_path: Path) -> None:
    scene = ROOT / "scenes" / "cornell_glass.usda"
    args = ["bench", str(scene), "--gaze", "0.6,0.55", "--out", str(tmp_path), "--size", "48x36", "--repeats", "1"]
    args += ["--fractions", "0.1,0.5", "--lowres", "0.5", "--reference-spp", "4", "--threads", "1"]
    args += ["--fovea-spp", "4", "--exposure", "0.5"]
    assert main(args) == 0
    with open(tmp_path / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[: len(RESULT_COLUMNS)] == list(RESULT_COLUMNS)
    assert [r["label"] for r in rows] == [c.label for c in sweep_configs([0.1, 0.5], [0.5], fovea_spp=4)]
    by = {r["label"]: r for r in rows}
    assert by["hybrid 50% x4 spp"]["spp"] == "4" and by["hybrid 50%"]["spp"] == "1"
    # Four window samples are the reference's first four: the window comes closer to it.
    assert float(by["hybrid 50% x4 spp"]["flip_inside"]) < float(by["hybrid 50%"]["flip_inside"])
    assert float(by["hybrid 50% x4 spp"]["fovea_primary_ms"]) > 0.0
    assert "exposure +0.50 EV" in (tmp_path / "results.md").read_text()
    for r in rows:
        assert float(r["ms"]) > 0.0 and 0.0 <= float(r["flip_foveated"]) <= 1.0
    # tracing more of the screen at the gaze brings the image closer to the traced reference
    assert float(by["hybrid 50%"]["flip_foveated"]) < float(by["raster"]["flip_foveated"])
    assert float(by["full"]["flip_mean"]) < float(by["raster"]["flip_mean"])
    assert "### cornell_glass" in (tmp_path / "results.md").read_text()
    plot = cv2.imread(str(tmp_path / "cornell_glass.png"))
    assert plot is not None and plot.shape[0] > 200 and plot.std() > 5


def test_bench_with_shadow_maps_shadows_the_periphery(tmp_path: Path) -> None:
    """``bench --shadow-maps --indirect``: every row and the reference take the switches;
    the raster rows get shadows like the traced reference, so the raster frame comes
    closer to it than without them."""
    scene = ROOT / "scenes" / "cornell_glass.usda"
    flips = {}
    for flag in ([], ["--shadow-maps", "--indirect"]):
        out = tmp_path / ("with" if flag else "without")
        args = ["bench", str(scene), "--gaze", "0.6,0.55", "--out", str(out), "--size", "48x36", "--repeats", "1"]
        args += ["--fractions", "0.1", "--lowres", "0.5", "--reference-spp", "2", "--threads", "1", "--exposure", "0"]
        assert main(args + flag) == 0
        with open(out / "results.csv") as f:
            flips[bool(flag)] = {r["label"]: float(r["flip_mean"]) for r in csv.DictReader(f)}
    assert flips[True]["raster"] < flips[False]["raster"]
