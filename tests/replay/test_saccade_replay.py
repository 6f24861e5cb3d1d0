"""Saccade-aware window placement (``--saccade``) in the replay loop, on a synthetic trace
with labelled saccades: the window goes to the predicted landing point during saccades,
stays at the gaze otherwise, and with the switch off nothing changes."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from gaze.screen import ScreenGeometry
from gaze.source import SACCADE
from gaze.trace.data import make_trace_data
from gaze.trace.playback import TraceSource
from warp_hybrid.adapt.saccade import SaccadePredictor, offset_by_angle
from warp_hybrid.cli import _loop_settings, build_parser
from warp_hybrid.renderer import RenderSettings
from warp_hybrid.replay.loop import AdaptiveLoop, LoopFrame, LoopSettings
from warp_hybrid.replay.run import ReplayOutputs, recorded_times, replay
from warp_hybrid.scene.open import open_scene_source

ROOT = Path(__file__).resolve().parents[2]
ANIMATED = ROOT / "scenes" / "textured_animated.usda"
W, H = 64, 48
FPS = 15.0
RATE = 250.0
SCREEN = ScreenGeometry()
#: (onset parameter s, start point, direction, amplitude deg): each lands before the next starts;
#: the frames at 8/15 s and 17/15 s see them in flight, past their peak speed
SACCADES = (
    (0.52, (0.3, 0.4), (1.0, 0.2), 12.0),
    (1.12, None, (-0.4, 1.0), 9.0),
)


def dai_angle(t: np.ndarray, amplitude: float, v_max: float = 600.0, c: float = 6.0) -> np.ndarray:
    """Dai et al.'s parametric saccade (IEEE SPMB 2016), peak speed ``v_max (1 - exp(-A / c))``."""

    def f(u: np.ndarray) -> np.ndarray:
        return np.where(u >= 0.0, u + 0.25 * np.exp(-2.0 * np.abs(u)), 0.25 * np.exp(-2.0 * np.abs(u)))

    return c * f(v_max * t / c) - c * f(v_max * (t - amplitude / v_max) / c)


def synthetic_trace() -> tuple[TraceSource, list[tuple[float, float]]]:
    """A 250 Hz trace of fixations joined by the main-sequence saccades above, and their end points."""
    t = np.arange(int(1.6 * RATE) + 1) / RATE
    point = SACCADES[0][1]
    x, y = np.full(t.shape, point[0]), np.full(t.shape, point[1])
    ends = []
    for onset, start, direction, amplitude in SACCADES:
        start = start or point
        moving = t >= onset - 0.05
        path = np.array([offset_by_angle(SCREEN, start, direction, a) for a in dai_angle(t[moving] - onset, amplitude)])
        x[moving], y[moving] = path[:, 0], path[:, 1]
        point = offset_by_angle(SCREEN, start, direction, amplitude)
        ends.append(point)
    data = make_trace_data(
        "synthetic.csv", "simple", t, x, y, np.ones_like(t), np.ones(t.shape, bool), np.arange(t.size)
    )
    return TraceSource(data, SCREEN), ends


def run(device: str, saccade: bool, adaptive: bool, clock=None) -> list[LoopFrame]:
    """Replay the synthetic trace over the animated scene; every finished frame."""
    source, _ = synthetic_trace()
    frames: list[LoopFrame] = []
    settings = RenderSettings(width=W, height=H, device=device, mode="hybrid", threads=1, window_fraction=0.1)
    loop_settings = LoopSettings(fps=FPS, adaptive=adaptive, saccade=saccade)
    options = {"clock": clock} if clock is not None else {}
    with AdaptiveLoop(open_scene_source(ANIMATED), settings, loop_settings, **options) as loop:
        replay(loop, source, 22, ReplayOutputs(), warm_up=1, progress=False, on_frame=frames.append)
    return frames


def centre(frame: LoopFrame) -> tuple[float, float]:
    """Where the frame's window was placed (normalised)."""
    return tuple(frame.frame.stats["window"]["gaze"])


def expected_landings(source: TraceSource, frames: list[LoopFrame]) -> dict[int, tuple[float, float]]:
    """An independent predictor fed what a tracker reported up to each frame (the recorded
    samples, then the frame's own): the landing each saccade frame should show."""
    predictor = SaccadePredictor(SCREEN)
    out = {}
    for frame in frames:
        for k in np.flatnonzero(source.data.t < frame.t):
            predictor.add(source.sample(float(source.data.t[k])))
        predictor.add(frame.gaze)
        landing = predictor.landing()
        if landing is not None:
            out[frame.index] = landing.point
    return out


def fake_clock():
    """A clock that advances 2 ms per reading: deterministic frame times."""
    ticks = itertools.count()
    return lambda: next(ticks) * 0.002


@pytest.mark.parametrize("adaptive", [False, True])
def test_the_window_goes_to_the_landing_point_during_saccades(device: str, adaptive: bool) -> None:
    frames = run(device, saccade=True, adaptive=adaptive, clock=fake_clock())
    source, ends = synthetic_trace()
    expected = expected_landings(source, frames)
    in_flight = [f for f in frames if f.gaze.label == SACCADE]
    assert [f.index for f in in_flight] == [8, 17] and sorted(expected) == [8, 17]
    for frame in frames:
        if frame.index in expected:
            assert centre(frame) == pytest.approx(expected[frame.index], abs=1e-12)
        else:
            assert centre(frame) == pytest.approx((frame.gaze.x, frame.gaze.y), abs=1e-12)
    for frame, end in zip(in_flight, ends):
        to_gaze = float(SCREEN.angle_deg(frame.gaze.x, frame.gaze.y, *end))
        to_window = float(SCREEN.angle_deg(*centre(frame), *end))
        assert to_gaze > 1.5 and to_window < 0.5 * to_gaze  # deg: the window waits where the eye lands
    if adaptive:
        assert all(f.plan is not None and f.plan.fraction == pytest.approx(f.window_fraction) for f in frames)


def test_with_the_switch_off_nothing_changes(device: str) -> None:
    off = run(device, saccade=False, adaptive=False)
    on = run(device, saccade=True, adaptive=False)
    assert all(centre(f) == pytest.approx((f.gaze.x, f.gaze.y), abs=1e-12) for f in off)
    for a, b in zip(off, on):
        if a.gaze.label == SACCADE:
            assert not np.array_equal(a.frame.image, b.frame.image)  # the window moved
        else:
            np.testing.assert_array_equal(a.frame.image, b.frame.image)


def test_recorded_times_are_the_samples_between_two_frames() -> None:
    source, _ = synthetic_trace()
    times = recorded_times(source, 0.5, 0.52)
    np.testing.assert_allclose(times, [0.504, 0.508, 0.512, 0.516])
    assert recorded_times(object(), 0.0, 1.0) == []  # a live source: no recording


def test_the_command_line_switch() -> None:
    parser = build_parser()
    base = ["replay", str(ANIMATED), "--gaze", "trace:x.csv", "--stats", "s.csv"]
    assert _loop_settings(parser.parse_args(base), 0.0, True, saccade=False).saccade is False
    args = parser.parse_args([*base, "--saccade"])
    assert args.saccade and _loop_settings(args, 0.0, True, saccade=args.saccade).saccade
    assert parser.parse_args(["view", str(ANIMATED), "--saccade"]).saccade
    assert LoopSettings().saccade is False
