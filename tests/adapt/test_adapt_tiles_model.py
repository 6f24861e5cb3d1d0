"""Budget controller internals: tile coverage, the synthetic cost model, the cost fit and the tile priors."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from warp_hybrid.adapt import BudgetController, ControllerSettings, SyntheticCost, TileGrid
from warp_hybrid.adapt.model import CostFit, StageHistory, TraceCostModel, _nnls_normal, solve_costs
from warp_hybrid.adapt.tiles import prefix_sums
from warp_hybrid.focus import FocusWindow


def window_mask(gaze, fraction, shape, w, h) -> np.ndarray:
    """(H, W) bool: the pixels the layout's row spans cover."""
    start, stop = FocusWindow(gaze, fraction, shape).layout(w, h).row_spans()
    cols = np.arange(w)
    return (cols >= start[:, None]) & (cols < stop[:, None])


def per_tile(values: np.ndarray, tile: int) -> np.ndarray:
    """Sum an (H, W[, C]) map over tile x tile blocks, brute force."""
    h, w = values.shape[:2]
    ty, tx = -(-h // tile), -(-w // tile)
    out = np.zeros((ty, tx) + values.shape[2:])
    for j, i in itertools.product(range(ty), range(tx)):
        out[j, i] = values[j * tile : (j + 1) * tile, i * tile : (i + 1) * tile].sum(axis=(0, 1))
    return out


CASES = [
    ((0.5, 0.5), 0.25, "circle"),
    ((0.0, 0.0), 0.1, "circle"),
    ((1.0, 0.9), 0.6, "circle"),  # larger than the screen's height: cut by the edges
    ((0.3, 0.7), 0.3, "rect"),
    ((0.5, 0.5), 1.0, "circle"),
    ((0.5, 0.5), 0.0, "rect"),
    ((0.97, 0.02), 0.003, "circle"),
]


@pytest.mark.parametrize("size", [(640, 480), (650, 470), (33, 17)])
@pytest.mark.parametrize("gaze,fraction,shape", CASES)
def test_tile_coverage_matches_the_layout(size, gaze, fraction, shape) -> None:
    w, h = size
    controller = BudgetController(ControllerSettings(budget_ms=16.0, tile_px=32), w, h, shape=shape)
    coverage = controller.tile_coverage(gaze, fraction)
    assert controller.tile_shape == (-(-h // 32), -(-w // 32)) == coverage.shape
    assert coverage.dtype == np.int64
    assert int(coverage.sum()) == FocusWindow(gaze, fraction, shape).layout(w, h).count
    np.testing.assert_array_equal(coverage, per_tile(window_mask(gaze, fraction, shape, w, h), 32))


def test_tile_sums_of_a_map_match_brute_force() -> None:
    rng = np.random.default_rng(3)
    w, h, tile = 97, 61, 16
    values = rng.random((h, w, 3))
    grid = TileGrid(w, h, tile)
    start, stop = grid.spans((0.4, 0.6), 0.35, "circle", 16.0)
    mask = window_mask((0.4, 0.6), 0.35, "circle", w, h)
    np.testing.assert_allclose(grid.sums(start, stop, prefix_sums(values)), per_tile(values * mask[..., None], tile))
    np.testing.assert_allclose(
        grid.sums(start, stop, prefix_sums(values[..., 0])), per_tile(values[..., 0] * mask, tile)
    )
    assert grid.tile_area.sum() == w * h


def test_synthetic_frame_measures_the_covered_pixels() -> None:
    cost = SyntheticCost.glass_disc(320, 240, before_ms=3.0, after_ms=1.0)
    gaze, fraction = (0.7, 0.5), 0.2
    frame = cost.frame(fraction, gaze)
    mask = window_mask(gaze, fraction, "circle", 320, 240)
    assert frame.trace_ms == pytest.approx(float(cost.pixel_ms[mask].sum()), rel=1e-12)
    assert frame.traced_pixels == int(mask.sum())
    assert frame.tile_rays.dtype.kind == "i"
    np.testing.assert_allclose(frame.tile_rays, per_tile(cost.rays * mask[..., None], 32), atol=0.5 + 1e-9)
    assert frame.frame_ms == pytest.approx(3.0 + frame.trace_ms + 1.0)
    assert cost.frame_index == 1


def test_synthetic_cost_is_deterministic_and_spikes_apply_over_their_frames() -> None:
    from warp_hybrid.adapt import Spike

    def trace_times(seed: int) -> list[float]:
        cost = SyntheticCost.glass_disc(160, 120, jitter=0.05, seed=seed, spikes=[Spike(2, 4, trace_scale=10.0)])
        return [cost.frame(0.3, (0.5, 0.5)).trace_ms for _ in range(6)]

    a, b, c = trace_times(1), trace_times(1), trace_times(2)
    assert a == b and a != c
    assert min(a[2], a[3]) > 5.0 * max(a[0], a[1], a[4], a[5])


def brute_nnls(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """min c.M.c - 2 b.c, c >= 0, by trying every support."""
    n = len(b)
    best, best_obj = np.zeros(n), 0.0
    for k in range(1, n + 1):
        for s in itertools.combinations(range(n), k):
            s = list(s)
            cs = np.linalg.solve(m[np.ix_(s, s)], b[s])
            if np.all(cs >= 0) and -b[s] @ cs < best_obj:
                best, best_obj = np.zeros(n), -b[s] @ cs
                best[s] = cs
    return best


def test_active_set_nnls_finds_the_constrained_optimum() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        x = rng.normal(size=(8, 5))
        m = x.T @ x + 1e-3 * np.eye(5)
        b = x.T @ rng.normal(size=8)
        np.testing.assert_allclose(_nnls_normal(m, b), brute_nnls(m, b), atol=1e-9)


TRUE_COSTS = np.array([0.0, 40.0, 40.0, 80.0, 200.0])  # ms: overhead, per million pixels, per million rays


def blocky_scene(w: int = 320, h: int = 240, seed: int = 0) -> SyntheticCost:
    """Ray densities drawn independently per 32 px tile, so every ray type's cost can be told apart."""
    rng = np.random.default_rng(seed)
    blocks = rng.uniform([0.5, 0.0, 0.0], [3.0, 2.0, 3.0], size=(-(-h // 32), -(-w // 32), 3))
    rays = np.repeat(np.repeat(blocks, 32, axis=0), 32, axis=1)[:h, :w]
    pixel_ms = (TRUE_COSTS[1] + rays @ TRUE_COSTS[2:]) / 1e6
    return SyntheticCost(pixel_ms, rays, before_ms=5.0, after_ms=1.0)


def random_frames(cost: SyntheticCost, n: int, seed: int = 0):
    """Frames of random windows at random gazes."""
    rng = np.random.default_rng(seed)
    return [cost.frame(float(rng.uniform(0.02, 0.6)), tuple(rng.uniform(0, 1, 2))) for _ in range(n)]


def test_cost_fit_recovers_the_per_ray_costs_from_varied_frames() -> None:
    # No prior: the frames alone tell the costs apart.
    settings = ControllerSettings(budget_ms=33.3, cost_prior=0.0)
    model = TraceCostModel(TileGrid(320, 240, 32), settings)
    for frame in random_frames(blocky_scene(), 60):
        model.learn(frame)
    np.testing.assert_allclose(model.costs[1:], TRUE_COSTS[1:], rtol=0.02)
    assert model.costs[0] == pytest.approx(0.0, abs=0.02)


def test_default_prior_predicts_windows_it_has_not_seen() -> None:
    # The default prior biases only what the frames barely tell apart, which matters little.
    settings = ControllerSettings(budget_ms=33.3)
    grid = TileGrid(320, 240, 32)
    model = TraceCostModel(grid, settings)
    cost = blocky_scene()
    for frame in random_frames(cost, 60):
        model.learn(frame)
    rng = np.random.default_rng(9)
    for _ in range(20):
        gaze, fraction = tuple(rng.uniform(0, 1, 2)), float(rng.uniform(0.05, 0.6))
        predicted = model.predict_spans(*grid.spans(gaze, fraction, "circle", 16.0))
        assert predicted == pytest.approx(cost.trace_ms(gaze, fraction), rel=0.05)


def test_cost_fit_gets_what_a_two_material_scene_can_tell() -> None:
    # Background and glass pixels: only their two costs (and the overhead) are identifiable.
    settings = ControllerSettings(budget_ms=33.3)
    model = TraceCostModel(TileGrid(320, 240, 32), settings)
    for frame in random_frames(SyntheticCost.glass_disc(320, 240), 40):
        model.learn(frame)
    c = model.costs
    assert np.all(c >= 0.0)
    background = c[1] + np.dot([1.0, 0.3, 0.0], c[2:])
    glass = c[1] + np.dot([2.0, 1.0, 3.0], c[2:])
    assert background == pytest.approx(104.0, rel=0.03) and glass == pytest.approx(800.0, rel=0.03)


def test_prediction_from_spans_equals_prediction_from_coverage() -> None:
    settings = ControllerSettings(budget_ms=33.3)
    grid = TileGrid(330, 250, 32)
    model = TraceCostModel(grid, settings)
    cost = SyntheticCost.glass_disc(330, 250)
    for g in [(0.2, 0.2), (0.7, 0.5), (0.5, 0.9)]:
        model.learn(cost.frame(0.15, g))
    for gaze, fraction in [((0.5, 0.5), 0.3), ((0.95, 0.05), 0.02), ((0.1, 0.9), 0.8), ((0.5, 0.5), 0.0)]:
        start, stop = grid.spans(gaze, fraction, "circle", 16.0)
        assert model.predict_spans(start, stop) == pytest.approx(model.predict(grid.counts(start, stop)), rel=1e-10)


def test_untraced_tiles_take_their_neighbours_then_the_global_mean() -> None:
    settings = ControllerSettings(budget_ms=33.3, tile_px=10)
    grid = TileGrid(100, 100, 10)
    model = TraceCostModel(grid, settings)
    pixels = np.zeros((10, 10), dtype=np.int64)
    rays = np.zeros((10, 10, 3), dtype=np.int64)
    pixels[1, 1], rays[1, 1] = 100, (300, 0, 0)  # 3 shadow rays per pixel
    pixels[8, 8], rays[8, 8] = 100, (100, 0, 0)  # 1 shadow ray per pixel
    from warp_hybrid.adapt import FrameCost

    model.learn(FrameCost(10.0, 1.0, 8.0, 1.0, pixels, rays))
    rpp = model.rays_per_pixel()[..., 0]
    assert rpp[1, 1] == pytest.approx(3.0, rel=0.05) and rpp[8, 8] == pytest.approx(1.0, rel=0.05)
    assert rpp[0, 2] == pytest.approx(3.0) and rpp[7, 9] == pytest.approx(1.0)  # neighbours
    assert rpp[5, 5] == pytest.approx(2.0)  # far from both: the mean of the traced pixels


def test_stage_history_is_unreals_weighted_mean() -> None:
    history = StageHistory(size=3, weight=0.5)
    assert np.isnan(history.mean())
    for v in (100.0, 1.0, 2.0, 4.0):  # 100 falls out of the 3-frame history
        history.add(v)
    assert history.mean() == pytest.approx((4.0 + 0.5 * 2.0 + 0.25 * 1.0) / 1.75)
    history.restart(7.0)
    assert history.mean() == 7.0


def test_cost_fit_of_collinear_frames_splits_by_the_equal_cost_prior() -> None:
    fit = CostFit.empty()
    x = np.array([1.0, 0.1, 0.1, 0.0, 0.0])
    fit.a, fit.b, fit.frame_info, fit.frames = np.outer(x, x) * 10, x * 2.0 * 10, x * x, 10
    costs = solve_costs(fit, 0.05)
    assert costs[1] == pytest.approx(costs[2])  # pixels and shadow rays never told apart
    assert costs @ x == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("gaze", [(0.75, 0.5), (0.25, 0.5), (0.5, 0.1), (0.0, 1.0)])
@pytest.mark.parametrize("room", [0.5, 3.0, 12.0, 25.0])
def test_largest_fitting_finds_the_largest_window_that_fits(gaze, room) -> None:
    from warp_hybrid.adapt import largest_fitting

    cost = SyntheticCost.glass_disc(320, 240)
    calls = []

    def trace_at(f: float) -> float:
        calls.append(f)
        return cost.trace_ms(gaze, f)

    f = largest_fitting(trace_at, room, 0.01, 1.0, guess=0.3)
    assert 0.01 <= f <= 1.0 and len(calls) <= 10
    if f == 0.01:
        assert cost.trace_ms(gaze, 0.01) > room or cost.trace_ms(gaze, 0.0101) > room
    elif f < 1.0:
        assert cost.trace_ms(gaze, f) <= room < cost.trace_ms(gaze, min(1.0, f * 1.01))
    else:
        assert cost.trace_ms(gaze, 1.0) <= room


def test_largest_fitting_edges() -> None:
    from warp_hybrid.adapt import largest_fitting

    assert largest_fitting(lambda f: 10.0 * f, -1.0, 0.05, 0.8) == 0.05  # no room at all
    assert largest_fitting(lambda f: 10.0 * f, 100.0, 0.05, 0.8) == 0.8  # everything fits
    assert largest_fitting(lambda f: 10.0 * f + 5.0, 4.0, 0.05, 0.8) == 0.05  # nothing fits
    assert largest_fitting(lambda f: 0.0, 1.0, 0.0, 0.5, guess=0.0) == 0.5
    assert largest_fitting(lambda f: 10.0 * f, 2.0, 0.0, 1.0, guess=0.0) == pytest.approx(0.2, rel=0.01)
