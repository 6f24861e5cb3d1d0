"""The supersampled focus window (``fovea_spp``): inside the window the image is the
supersampled full ray tracing's, pixel for pixel; outside it, and in the G-buffer, it is
the one-sample hybrid frame; every sample's rays are counted; it takes no deadline."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_modes import H, W, mirror_scene

from warp_hybrid.cli import main
from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.focus import FocusWindow
from warp_hybrid.metrics import layout_mask
from warp_hybrid.renderer import Renderer, RenderSettings

WINDOW = FocusWindow(gaze=(0.35, 0.5), fraction=0.25, shape="circle", feather_px=0.0)


def _render(scene, device: str, **changes):
    settings = RenderSettings(
        width=W, height=H, device=device, primary="raycast", exposure_ev=0.0, antialias=False, **changes
    )
    with Renderer(scene, settings) as r:
        return r.render(scene.cameras[0], WINDOW)


@pytest.fixture(scope="module")
def frames(device: str) -> dict[str, object]:
    scene = mirror_scene()
    return {
        "fovea": _render(scene, device, mode="hybrid", fovea_spp=4),
        "hybrid": _render(scene, device, mode="hybrid"),
        "full": _render(scene, device, mode="full", spp=4),
        "full1": _render(scene, device, mode="full"),
    }


def test_inside_the_window_it_is_the_supersampled_full_frame(frames) -> None:
    inside = layout_mask(WINDOW.layout(W, H))
    fovea, full, full1 = frames["fovea"], frames["full"], frames["full1"]
    np.testing.assert_array_equal(fovea.color[inside], full.color[inside])
    vis = fovea.visibility[inside]
    np.testing.assert_array_equal(vis, full.visibility[inside])
    # The samples did something: four samples differ from one along the sphere's edges.
    assert np.abs(fovea.color[inside] - full1.color[inside]).max() > 0.05


def test_outside_the_window_and_the_gbuffer_are_the_one_sample_hybrid(frames) -> None:
    outside = ~layout_mask(WINDOW.layout(W, H))
    fovea, hybrid = frames["fovea"], frames["hybrid"]
    np.testing.assert_array_equal(fovea.color[outside], hybrid.color[outside])
    assert np.isnan(fovea.visibility[outside]).all()
    for name, channel in hybrid.gbuffer.aovs().items():
        np.testing.assert_array_equal(fovea.gbuffer.aovs()[name], channel, err_msg=name)


def test_every_sample_is_counted(frames) -> None:
    fovea, hybrid = frames["fovea"], frames["hybrid"]
    assert fovea.stats["fovea_spp"] == 4 and hybrid.stats["fovea_spp"] == 1
    pixels = hybrid.stats["window"]["pixels"]
    assert fovea.stats["window"]["pixels"] == pixels
    assert fovea.stats["rays"]["traced_pixels"] == 4 * pixels == 4 * hybrid.stats["rays"]["traced_pixels"]
    assert fovea.stats["stages_ms"]["fovea_primary"] > 0.0


def test_a_supersampled_window_takes_no_deadline(device: str) -> None:
    scene = mirror_scene()
    settings = RenderSettings(width=16, height=12, device=device, mode="hybrid", fovea_spp=2)
    with Renderer(scene, settings) as r, pytest.raises(RenderSettingsError, match="no budget guard"):
        r.render(scene.cameras[0], WINDOW, trace_deadline=1.0)


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"fovea_spp": 0}, "window samples per pixel must be in 1..256"),
        ({"fovea_spp": 3.0}, "RenderSettings.fovea_spp must be an integer"),
        ({"fovea_spp": 4, "mode": "full"}, "need mode 'hybrid'"),
        ({"fovea_spp": 4, "mode": "raster"}, "need mode 'hybrid'"),
    ],
)
def test_bad_fovea_spp_is_rejected(changes: dict, message: str) -> None:
    with pytest.raises(RenderSettingsError, match=message):
        RenderSettings(**{"mode": "hybrid", **changes}).validate()


def test_cli_fovea_spp(tmp_path, capsys) -> None:
    """``render --fovea-spp`` records it and counts every sample's rays; the adaptive
    loop (``--fps``, ``replay``) and the other modes refuse it in one line."""
    cornell = Path(__file__).resolve().parents[2] / "scenes" / "cornell_glass.usda"
    stats = tmp_path / "stats.json"
    args = ["render", str(cornell), "-o", str(tmp_path / "out.png"), "--size", "32x24", "--window", "0.3"]
    assert main([*args, "--fovea-spp", "3", "--stats-json", str(stats)]) == 0
    recorded = json.loads(stats.read_text())
    assert recorded["fovea_spp"] == 3 and recorded["rays"]["traced_pixels"] == 3 * recorded["window"]["pixels"]
    capsys.readouterr()
    for bad, message in (
        (["--fovea-spp", "4", "--fps", "15"], "--fovea-spp 4: render --fps"),
        (["--fovea-spp", "4", "--mode", "full"], "need mode 'hybrid'"),
    ):
        assert main([*args, *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and err.count("\n") == 1
    replay = ["replay", str(cornell), "--gaze", "fixed:0.5,0.5", "--fovea-spp", "2", "--frames", "1"]
    assert main([*replay, "--stats", str(tmp_path / "s.csv")]) == 2
    assert "--fovea-spp 2: replay" in capsys.readouterr().err
