"""``--saccade`` on and off: the error of the frame on screen when each saccade lands.

Replays a gaze trace over a scene (``replay.run.replay``, as ``warp-hybrid replay``)
once without and once with the saccade switch.  A frame whose gaze is labelled a
saccade is shown while the eye is in flight and is the frame it sees when it lands (a
frame stays on screen for 1 / fps); its landing point is the gaze of the next frame
not labelled a saccade.  Per setting: the saccade frames, the mean visual angle from
their window's centre to the landing point (from the gaze's, without the switch), their
foveated FLIP around the landing point (``metrics.evaluate``'s acuity weighting) and
their mean FLIP within 5 deg of it, the foveated FLIP of the first frame after landing
around its own gaze, and the mean traced share of all frames.  References: ``--mode
full --spp 16`` of the same scene time, exposed at each frame's own EV.

``--trace main-sequence`` replays a synthetic 250 Hz trace (12 s, seeded) whose
saccades follow Dai et al.'s parametric profile with the predictor's main sequence
(600 deg/s, 6 deg), 5-20 deg long between fixations 0.45-0.9 s apart; the default is
the shipped demo trace (60 Hz, 50 ms minimum-jerk saccades).  With ``--window F`` the
window is fixed (the runs differ only where the window is placed: deterministic);
without it the budget controller sizes it under the real clock (one run each, noisy).

    .venv/bin/python scripts/bench_saccade.py [--trace PATH|main-sequence] [--start S] [--fps 15]
        [--size 160x120] [--window F] [--order off,on] [--json out/bench_saccade.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from bench_common import ROOT, shared_scenes_dir

SCENE = shared_scenes_dir() / "cornell_box" / "cornell_box_glass_mirror.usda"
DEMO_TRACE = ROOT / "scenes" / "traces" / "demo_gaze.csv"
FOVEA_DEG = 5.0


@dataclasses.dataclass
class Kept:
    """What the error of one replayed frame needs."""

    index: int
    t: float
    gaze: tuple[float, float]
    label: str
    centre: tuple[float, float]
    traced: float
    exposure_ev: float
    srgb: np.ndarray


def dai_angle(t: np.ndarray, amplitude: float, v_max: float = 600.0, c: float = 6.0) -> np.ndarray:
    """Dai et al.'s parametric saccade (IEEE SPMB 2016): the angle (deg) ``t`` s after its
    onset parameter; its peak speed is ``v_max (1 - exp(-A / c))``."""

    def f(u: np.ndarray) -> np.ndarray:
        return np.where(u >= 0.0, u + 0.25 * np.exp(-2.0 * np.abs(u)), 0.25 * np.exp(-2.0 * np.abs(u)))

    return c * f(v_max * t / c) - c * f(v_max * (t - amplitude / v_max) / c)


def write_main_sequence_trace(path: Path, seed: int = 7, rate: float = 250.0, duration: float = 12.0) -> None:
    """The synthetic main-sequence trace (module notes) as the simple CSV."""
    from gaze.screen import ScreenGeometry
    from gaze.trace.simple_csv import write_simple
    from warp_hybrid.adapt.saccade import offset_by_angle

    rng = np.random.default_rng(seed)
    screen = ScreenGeometry()
    t = np.arange(int(duration * rate) + 1) / rate
    x, y = np.full(t.shape, 0.5), np.full(t.shape, 0.5)
    point, onset = (0.5, 0.5), 0.6
    while onset < duration - 0.6:
        for _ in range(100):  # a target 5-20 deg away, well inside the screen
            amplitude = float(rng.uniform(5.0, 20.0))
            angle = float(rng.uniform(0.0, 2.0 * math.pi))
            direction = (math.cos(angle), math.sin(angle))
            end = offset_by_angle(screen, point, direction, amplitude)
            if 0.1 < end[0] < 0.9 and 0.1 < end[1] < 0.9 and abs(screen.angle_deg(*point, *end) - amplitude) < 1e-6:
                break
        moving = t >= onset - 0.05
        path_points = [offset_by_angle(screen, point, direction, a) for a in dai_angle(t[moving] - onset, amplitude)]
        x[moving], y[moving] = np.array(path_points).T
        point = end
        onset += float(rng.uniform(0.45, 0.9))
    write_simple(path, t, x, y, np.ones_like(t), np.ones(t.shape, bool))


def replay_once(args: argparse.Namespace, trace: Path, saccade: bool, references: dict) -> dict[str, Any]:
    """One replay with the switch as given; its saccade frames' errors and the summary."""
    import warp as wp

    from gaze.factory import open_source
    from gaze.screen import ScreenGeometry
    from gaze.source import SACCADE
    from warp_hybrid.metrics import ViewingSetup, acuity_weight, flip_map, foveated_mean
    from warp_hybrid.post.postprocess import PostProcess
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.replay.loop import AdaptiveLoop, LoopFrame, LoopSettings
    from warp_hybrid.replay.run import ReplayOutputs, replay
    from warp_hybrid.scene.open import open_scene_source
    from warp_hybrid.timing import StageTimer

    width, height = (int(v) for v in args.size.split("x"))
    extra = {"window_fraction": args.window} if args.window else {}
    settings = RenderSettings(width=width, height=height, mode="hybrid", **extra)
    loop_settings = LoopSettings(fps=args.fps, adaptive=args.window is None, start=args.start, saccade=saccade)
    source = open_scene_source(args.scene)
    viewing, screen = ViewingSetup(), ScreenGeometry()
    kept: list[Kept] = []

    def keep(frame: LoopFrame) -> None:
        g = frame.gaze
        centre = tuple(frame.frame.stats["window"]["gaze"])
        ev = float(frame.frame.stats["exposure_ev"])
        kept.append(
            Kept(frame.index, frame.t, (g.x, g.y), g.label, centre, frame.traced_fraction, ev, frame.frame.image.copy())
        )

    rows = []
    with open_source(f"trace:{trace}") as gaze, AdaptiveLoop(source, settings, loop_settings) as loop:
        frames = round((gaze.duration - args.start) * args.fps)
        replay(loop, gaze, frames, ReplayOutputs(), warm_up=3, progress=False, on_frame=keep)
        rs = loop.renderer.settings
        with Renderer(loop.scene, dataclasses.replace(rs, mode="full", spp=16, fovea_spp=1, exposure_ev=0.0)) as ref:
            post = PostProcess(ref.launcher)

            def reference(k: Kept) -> np.ndarray:
                code = loop.time_code(k.t)
                if code not in references:
                    scene = source.scene_at(code)
                    ref.update_scene(scene)
                    references[code] = ref.render(loop.camera_in(scene)).color
                linear = wp.array(references[code], dtype=wp.vec3, device=ref.device)
                return post.process(linear, k.exposure_ev, rs.tonemap, rs.antialias, StageTimer()).numpy()

            for i, k in enumerate(kept):
                after = next((a for a in kept[i + 1 :] if a.label != SACCADE), None)
                if k.label != SACCADE or after is None:
                    continue
                error = flip_map(reference(k), k.srgb, viewing)
                eccentricity = viewing.eccentricity_deg(error.shape, after.gaze)
                error_after = flip_map(reference(after), after.srgb, viewing)
                weight_after = acuity_weight(viewing.eccentricity_deg(error.shape, after.gaze))
                rows.append(
                    {
                        "frame": k.index,
                        "traced_fraction": k.traced,
                        "window_to_landing_deg": float(screen.angle_deg(*k.centre, *after.gaze)),
                        "flip_foveated_at_landing": foveated_mean(error, acuity_weight(eccentricity)),
                        "flip_fovea5_at_landing": float(error[eccentricity <= FOVEA_DEG].mean()),
                        "flip_foveated_after": foveated_mean(error_after, weight_after),
                    }
                )
    summary: dict[str, Any] = {"saccade": saccade, "frames": len(kept), "saccade_frames": len(rows)}
    for key in ("window_to_landing_deg", "flip_foveated_at_landing", "flip_fovea5_at_landing", "flip_foveated_after"):
        summary[key] = statistics.fmean(r[key] for r in rows) if rows else math.nan
    summary["traced_pct_all_frames"] = 100.0 * statistics.fmean(k.traced for k in kept)
    summary["per_frame"] = rows
    return summary


def main(argv: list[str] | None = None) -> int:
    """Replay off and on, print one row each, optionally write the JSON."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=str(SCENE))
    p.add_argument("--trace", default=str(DEMO_TRACE), help="a trace file, or main-sequence (default: the demo trace)")
    p.add_argument("--start", type=float, default=0.0, help="first frame's time, s (default 0)")
    p.add_argument("--fps", type=float, default=15.0)
    p.add_argument("--size", default="160x120")
    p.add_argument("--window", type=float, default=None, help="a fixed window (default: the budget controller)")
    p.add_argument("--order", default="off,on", help="which run goes first (default off,on)")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    from warp_hybrid.runtime import init_warp

    init_warp()
    references: dict = {}
    with tempfile.TemporaryDirectory() as folder:
        trace = Path(args.trace)
        if args.trace == "main-sequence":
            trace = Path(folder) / "main_sequence.csv"
            write_main_sequence_trace(trace)
        runs = [replay_once(args, trace, order == "on", references) for order in args.order.split(",")]
    print(
        "saccade | saccade frames | window to landing deg | fov. FLIP at landing | FLIP <= 5 deg | next frame | traced %"
    )
    for r in runs:
        print(
            f"{'on' if r['saccade'] else 'off'} | {r['saccade_frames']} | {r['window_to_landing_deg']:.2f} | "
            f"{r['flip_foveated_at_landing']:.4f} | {r['flip_fovea5_at_landing']:.4f} | "
            f"{r['flip_foveated_after']:.4f} | {r['traced_pct_all_frames']:.1f}"
        )
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"args": vars(args), "runs": runs}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
