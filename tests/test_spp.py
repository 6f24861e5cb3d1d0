"""Supersampling (``--spp``): one sample is the pixel-centre render, the stratified
pattern covers every stratum, the raster and ray-cast paths sample the jittered point
(unclipped and clipped triangles), the box filter converges, and a render is
reproducible."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from warp_hybrid.cli import main
from warp_hybrid.core.camera import SAMPLE_GRID, make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer, RayCaster
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Camera, Light, LightKind, Material, TextureBinding, TextureImage
from warp_hybrid.supersample import MAX_SPP, sample_offsets, sample_step, strata
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace.tracer import sample_seed

W, H = 64, 48
CORNELL = Path(__file__).resolve().parents[1] / "scenes" / "cornell_glass.usda"


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float], material: int) -> list[MeshInput]:
    """An axis-aligned box as six quads."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    return [
        quad((x0, y0, z1), (dx, 0, 0), (0, dy, 0), material, "/box/front"),
        quad((x1, y0, z0), (-dx, 0, 0), (0, dy, 0), material, "/box/back"),
        quad((x0, y0, z0), (0, 0, dz), (0, dy, 0), material, "/box/left"),
        quad((x1, y0, z1), (0, 0, -dz), (0, dy, 0), material, "/box/right"),
        quad((x0, y1, z1), (dx, 0, 0), (0, 0, -dz), material, "/box/top"),
        quad((x0, y0, z0), (dx, 0, 0), (0, 0, dz), material, "/box/bottom"),
    ]


def edge_scene():
    """Sharp edges only: a matte box and sphere on a floor under a sun (hard shadows),
    black background, so every pixel an edge (silhouette or shadow) crosses mixes two
    flat colours and nothing else varies inside a pixel."""
    mats = [
        Material("floor", diffuse=(0.7, 0.7, 0.7), roughness=1.0),
        Material("box", diffuse=(0.8, 0.3, 0.1), roughness=1.0),
        Material("ball", diffuse=(0.1, 0.4, 0.8), roughness=1.0),
    ]
    meshes = [
        quad((-5, 0, 5), (10, 0, 0), (0, 0, -10), 0, "/floor"),
        *_box((-1.6, 0.0, -0.6), (-0.2, 1.2, 0.6), 1),
        uv_sphere((1.0, 0.7, 0.2), 0.7, 24, 48, 2, "/ball"),
    ]
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(0.5, -1.0, -0.3))
    cam = look_at_camera((0.8, 2.6, 5.0), (0.0, 0.5, 0.0), hfov_deg=55.0)
    return make_scene(meshes, mats, [sun], [cam])


def _render(scene, spp: int, device: str, **kw) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    settings = RenderSettings(width=W, height=H, device=device, mode="full", spp=spp, exposure_ev=0.0, **kw)
    with Renderer(scene, settings) as r:
        frame = r.render(scene.cameras[0])
    return frame.color, frame.image, frame.aovs(), frame.stats


@pytest.fixture(scope="module")
def scene():
    return edge_scene()


@pytest.fixture(scope="module")
def renders(scene, device: str) -> dict[int, tuple]:
    """The edge scene at 1, 4, 16 and 64 samples per pixel."""
    return {spp: _render(scene, spp, device) for spp in (1, 4, 16, 64)}


# ---- the sample pattern ------------------------------------------------------


@pytest.mark.parametrize(
    "spp, grid", [(2, (2, 1)), (4, (2, 2)), (7, (7, 1)), (8, (4, 2)), (9, (3, 3)), (12, (4, 3)), (16, (4, 4))]
)
def test_strata_grid(spp: int, grid: tuple[int, int]) -> None:
    assert strata(spp) == grid
    assert sample_step(spp) == (1.0 / grid[0], 1.0 / grid[1])


@pytest.mark.parametrize("spp", [2, 4, 7, 8, 9, 12, 16, 64, 255, MAX_SPP])
@pytest.mark.parametrize("seed", [0, 1, 12345])
def test_offsets_cover_every_stratum_once(spp: int, seed: int) -> None:
    """Sub-frame k's offset lies in (the closed) stratum (k % nx, k // nx), so the N
    sub-frames put exactly one sample in each of the pixel's N strata; all on the
    fixed-point grid, inside the pixel; mirrored pairwise through the centre, so their
    mean is the centre exactly."""
    nx, ny = strata(spp)
    offsets = sample_offsets(spp, seed)
    assert offsets.shape == (spp, 2)
    assert ((offsets >= 0.0) & (offsets <= 1.0)).all()
    np.testing.assert_array_equal(offsets * SAMPLE_GRID, np.round(offsets * SAMPLE_GRID))
    k = np.arange(spp)
    lo = np.stack([k % nx / nx, k // nx / ny], axis=1)
    hi = np.stack([(k % nx + 1) / nx, (k // nx + 1) / ny], axis=1)
    assert ((offsets >= lo - 1e-12) & (offsets <= hi + 1e-12)).all()
    cells = {(i, j) for i, j in zip(k % nx, k // nx, strict=True)}
    assert len(cells) == nx * ny == spp
    if spp <= 16:  # strata at least 64 grid steps wide: the points are jittered, not the strata's corners
        assert len({tuple(o) for o in offsets - lo}) > 1
    np.testing.assert_array_equal(offsets[::-1], 1.0 - offsets)
    assert offsets.mean(axis=0).tolist() == [0.5, 0.5]


def test_offsets_are_seeded_and_one_sample_is_the_centre() -> None:
    np.testing.assert_array_equal(sample_offsets(16, 3), sample_offsets(16, 3))
    assert not np.array_equal(sample_offsets(16, 3), sample_offsets(16, 4))
    np.testing.assert_array_equal(sample_offsets(1, 7), [[0.5, 0.5]])
    # The odd grid's centre stratum takes the centre; the others are jittered.
    nine = sample_offsets(9, 2)
    assert nine[4].tolist() == [0.5, 0.5] and len({tuple(o) for o in np.delete(nine, 4, axis=0) % (1 / 3)}) > 1


def test_shadow_seed_per_sample() -> None:
    """Sample 0 keeps the tracer's seed (one sample per pixel is unchanged); the others
    get distinct seeds, none of which the kernel's per-light and per-segment steps
    (7919, 104729) turn into another's, and far from int32 overflow."""
    assert sample_seed(0, 0) == 0 and sample_seed(17, 0) == 17
    seeds = [sample_seed(5, k) for k in range(MAX_SPP)]
    assert len(set(seeds)) == MAX_SPP
    assert max(seeds) < 2**30
    steps = {dl * 7919 + ds * 104729 for dl in range(-64, 65) for ds in range(-16, 17)}
    assert not {a - b for a in seeds for b in seeds if a != b} & steps


def test_camera_sample_defaults_to_the_centre() -> None:
    cam = look_at_camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    c = make_camera_gpu(cam, W, H)
    assert tuple(c.sample) == (0.5, 0.5) and tuple(c.sample_step) == (1.0, 1.0)
    snapped = make_camera_gpu(cam, W, H, sample=(0.3, 0.9999))
    assert tuple(snapped.sample) == (77 / 256, 1.0)
    with pytest.raises(ValueError, match="sample offset"):
        make_camera_gpu(cam, W, H, sample=(1.5, 0.5))


# ---- coverage at the sample point --------------------------------------------


def _screen_camera() -> Camera:
    """At the origin looking down -Z, tan(half hfov) = 1: (X, Y, -1) lands on screen
    (32 + 32 X, 24 - 32 Y) at 64x48."""
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.05, 1.0e4)


def _screen_quad(x0: float, x1: float, y0: float, y1: float) -> MeshInput:
    left, right = (x0 - 32.0) / 32.0, (x1 - 32.0) / 32.0
    top, bottom = (24.0 - y0) / 32.0, (24.0 - y1) / 32.0
    return quad((left, bottom, -1.0), (right - left, 0.0, 0.0), (0.0, top - bottom, 0.0))


def _gbuffer(
    scene, camera: Camera, device: str, path: str, sample: tuple[float, float], step: tuple[float, float] = (1.0, 1.0)
) -> GBuffer:
    gb = GBuffer(W, H, device)
    with Launcher(device, threads=1) as launcher:
        primary = Rasterizer(launcher) if path == "raster" else RayCaster(launcher)
        cam = make_camera_gpu(camera, W, H, sample=sample, sample_step=step)
        primary.render(DeviceScene(scene, device), cam, gb, StageTimer())
    return gb


def _coverage(scene, camera: Camera, device: str, path: str, sample: tuple[float, float]) -> np.ndarray:
    return _gbuffer(scene, camera, device, path, sample).triangle_id.numpy()


@pytest.mark.parametrize("path", ["raster", "raycast"])
@pytest.mark.parametrize("sample", [(0.25, 0.75), (0.75, 0.25), (0.0, 0.0), (0.5, 0.5)])
def test_coverage_tests_the_sample_point(device: str, path: str, sample: tuple[float, float]) -> None:
    """Pixel (i, j) is covered when its sample point (i + sx, j + sy) is inside the quad
    (top and left edges own the points on them); the quad's edges are chosen so that
    each offset, and the opposite shift, give different pixels."""
    x0, x1, y0, y1 = 10.25, 20.3, 5.75, 15.6
    scene = make_scene([_screen_quad(x0, x1, y0, y1)], [Material("m")])
    sx, sy = sample
    px = np.arange(W) + sx
    py = np.arange(H) + sy
    expected = ((py >= y0) & (py < y1))[:, None] & ((px >= x0) & (px < x1))[None, :]
    got = _coverage(scene, _screen_camera(), device, path, sample) >= 0
    np.testing.assert_array_equal(got, expected)


def test_clipped_triangles_sample_the_point_too(device: str) -> None:
    """A huge floor crossing the near plane takes the clipped path; its far apex lies at
    screen y = 24 + 32 / 1000: row 24 is covered when sampled at its centre (24.5), not
    at its top edge (24.0); the ray cast agrees."""
    floor = MeshInput(np.array([[-1e3, -1, 1e3], [1e3, -1, 1e3], [0, -1, -1e3]], np.float32), np.array([[0, 1, 2]]))
    scene = make_scene([floor], [Material("m")])
    cam = Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.01, 1.0e4)
    for path in ("raster", "raycast"):
        centre = _coverage(scene, cam, device, path, (0.5, 0.5)) >= 0
        top = _coverage(scene, cam, device, path, (0.5, 0.0)) >= 0
        assert not centre[:24].any() and centre[24:].all()
        assert not top[:25].any() and top[25:].all()


def test_raster_matches_raycast_at_a_jittered_sample(device: str, scene) -> None:
    """On the edge scene at offset (0.2, 0.8): the same triangle in >= 99.5% of pixels
    and the same background, as at the pixel centres (differences only on inner edges)."""
    cam = scene.cameras[0]
    a = _coverage(scene, cam, device, "raster", (0.2, 0.8))
    b = _coverage(scene, cam, device, "raycast", (0.2, 0.8))
    np.testing.assert_array_equal(a >= 0, b >= 0)
    assert (a == b).mean() >= 0.995
    assert not np.array_equal(a, _coverage(scene, cam, device, "raster", (0.5, 0.5)))


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_texture_footprint_spans_one_sample(device: str, path: str) -> None:
    """A one-texel checker at 7 texels per pixel: a one-sample camera filters the pixel's
    footprint (level 2.8, grey 0.5); a camera whose samples are 1/8 pixel apart filters
    only its sample's 7/8 texel (level 0: the pixel centres sit on texel centres, 0 or 1),
    leaving the averaging to the box filter over the samples."""
    n = 56
    on = (np.add.outer(np.arange(n), np.arange(n)) % 2).astype(np.float32)
    img = np.concatenate([np.repeat(on[..., None], 3, axis=2), np.ones((n, n, 1), np.float32)], axis=2)
    scene = make_scene(
        [quad((-1.0, -1.0, -8.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), 0)],
        [Material("checker", diffuse_texture=0)],
        images=[TextureImage("<checker>", img)],
        textures=[TextureBinding(0)],
    )
    pixel = _gbuffer(scene, _screen_camera(), device, path, (0.5, 0.5)).albedo.numpy()[21:27, 29:35]
    sample = _gbuffer(scene, _screen_camera(), device, path, (0.5, 0.5), (0.125, 0.125)).albedo.numpy()[21:27, 29:35]
    np.testing.assert_allclose(pixel, 0.5, atol=1e-4)
    assert np.abs(sample - 0.5).min() > 0.4


# ---- the renderer ------------------------------------------------------------


def test_one_sample_is_todays_pixel_centre_render(scene, device: str, renders) -> None:
    """spp 1 is the default and runs the plain pass list: no accumulation, and the same
    colour, image and AOVs as settings that never mention spp."""
    color, image, aovs, stats = renders[1]
    with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode="full", exposure_ev=0.0)) as r:
        frame = r.render(scene.cameras[0])
    assert RenderSettings().spp == 1
    assert np.array_equal(color, frame.color) and np.array_equal(image, frame.image)
    for k, v in frame.aovs().items():
        assert np.array_equal(aovs[k], v, equal_nan=True), k
    assert stats["spp"] == 1 and "accumulate" not in stats["stages_ms"]
    assert stats["rays"]["traced_pixels"] == W * H


def test_supersampled_frame_keeps_the_centre_gbuffer(renders) -> None:
    """The G-buffer AOVs of a 16-sample frame are the pixel centres', bit for bit; the
    stages sum over the samples and the rays cover all of them."""
    _, _, one, _ = renders[1]
    _, _, many, stats = renders[16]
    for k in ("depth", "position", "normal", "albedo"):
        assert np.array_equal(one[k], many[k], equal_nan=True), k
    assert stats["spp"] == 16
    assert stats["rays"]["traced_pixels"] == 16 * W * H
    assert {"raster", "resolve", "surface", "trace_shadow", "trace_secondary", "accumulate"} <= set(stats["stages_ms"])
    assert stats["frame_ms"] == pytest.approx(sum(stats["stages_ms"].values()))


def test_box_filter_converges(renders) -> None:
    """Mean absolute error of the linear colour against 64 samples falls with the
    samples per pixel, and at 16 it is below 40% of the one-sample error.

    Why 40%: every error sits on an edge between two flat colours (contrast C).  The
    pixel centre misses the pixel's coverage a by |a - round(a)|, C / 4 on average over
    the edge pixels.  With an n x n stratified grid only the ~1.5 n strata an edge
    crosses are random, each contributing a Bernoulli term of at most 1/4 variance, so
    the error is about C sqrt(1.5 n / 4) / n^2, ~0.04 C at n = 4 (the 1 / N^(3/4)
    of stratified sampling), against ~0.02 C for the 64-sample reference itself:
    together ~0.05 C, a fifth of C / 4.  The bound leaves twice that margin."""
    ref = renders[64][0]
    mae = {spp: float(np.abs(renders[spp][0] - ref).mean()) for spp in (1, 4, 16)}
    assert mae[1] > mae[4] > mae[16] > 0.0
    assert mae[16] < 0.4 * mae[1]
    # The filter keeps the image's energy: the mean colour barely moves.
    np.testing.assert_allclose(renders[16][0].mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.01)


def test_supersampled_render_is_reproducible(scene, device: str, renders) -> None:
    """Same settings, same image, on another renderer and on a second frame of one
    renderer; another seed jitters other points."""
    color, image, _, _ = renders[16]
    settings = RenderSettings(width=W, height=H, device=device, mode="full", spp=16, exposure_ev=0.0)
    with Renderer(scene, settings) as r:
        first = r.render(scene.cameras[0])
        second = r.render(scene.cameras[0])
    for frame in (first, second):
        assert np.array_equal(frame.color, color) and np.array_equal(frame.image, image)
    other, _, _, _ = _render(scene, 16, device, sample_seed=1)
    assert not np.array_equal(other, color)
    assert np.abs(other - color).mean() < np.abs(renders[1][0] - renders[64][0]).mean()


def test_visibility_is_the_mean_over_the_samples(renders) -> None:
    """A hard shadow seen at one sample is 0 or 1; averaged over 16, pixels on the
    shadow's edge take fractions.  NaN only where no sample hit a surface."""
    one = renders[1][2]["visibility"][..., 0]
    many = renders[16][2]["visibility"][..., 0]
    lit = one[np.isfinite(one)]
    assert set(np.unique(lit)) <= {0.0, 1.0}
    v = many[np.isfinite(many)]
    assert ((v >= 0.0) & (v <= 1.0)).all()
    assert ((v > 0.05) & (v < 0.95)).sum() >= 10
    assert (np.isfinite(many) | np.isnan(one)).all()  # a centre that hits a surface has a visibility
    assert np.isnan(many).sum() > 0


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"spp": 0}, "samples per pixel must be in 1..256"),
        ({"spp": -4}, "samples per pixel must be in 1..256"),
        ({"spp": 257}, "samples per pixel must be in 1..256"),
        ({"spp": 2.0}, "RenderSettings.spp must be an integer"),
        ({"spp": True}, "RenderSettings.spp must be an integer"),
        ({"spp": 4, "mode": "hybrid"}, "need mode 'full'"),
        ({"spp": 4, "mode": "raster"}, "need mode 'full'"),
        ({"spp": 4, "sample_seed": 0.5}, "RenderSettings.sample_seed must be an integer"),
    ],
)
def test_bad_spp_is_rejected(changes: dict, message: str) -> None:
    settings = RenderSettings(**{"mode": "full", **changes})
    with pytest.raises(RenderSettingsError, match=message):
        settings.validate()


def test_cli_spp(tmp_path, capsys) -> None:
    """``render --spp`` records it in the stats; bad values and the commands that render
    one sample per pixel say so in one line with status 2."""
    stats = tmp_path / "stats.json"
    args = ["render", str(CORNELL), "-o", str(tmp_path / "out.png"), "--size", "32x24", "--mode", "full"]
    assert main([*args, "--spp", "4", "--stats-json", str(stats)]) == 0
    recorded = json.loads(stats.read_text())
    assert recorded["spp"] == 4 and recorded["rays"]["traced_pixels"] == 4 * 32 * 24
    capsys.readouterr()
    for bad, message in (
        (["--spp", "0"], "samples per pixel must be in 1..256"),
        (["--spp", "4", "--mode", "hybrid"], "need mode 'full'"),
        (["--spp", "4", "--fps", "15"], "--spp"),
    ):
        assert main([*args, *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and err.count("\n") == 1
    replay = ["replay", str(CORNELL), "--gaze", "fixed:0.5,0.5", "--mode", "full", "--spp", "4"]
    assert main([*replay, "--frames", "1", "--stats", str(tmp_path / "s.csv")]) == 2
    assert "--spp" in capsys.readouterr().err
    assert not (tmp_path / "s.csv").exists()
