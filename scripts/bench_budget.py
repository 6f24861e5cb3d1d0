"""The adaptive loop against its budget: the paper's "traced area at 15 FPS" for our scenes.

For each shared scene (its own entry for each ``*_animated`` layer) at 640x480, replays
the shipped gaze trace (``scenes/traces/demo_gaze.csv``, 5 s) at ``--fps`` (15) through
``replay.loop.AdaptiveLoop`` with the real clock, after a warm-up, and reports: the
raster-only frame time (median; where it exceeds the budget, no window size can meet
it and the scene is marked infeasible), frames within the budget and within the
budget + 10% (%), the mean traced area (% of the screen: the paper's figure), frame
time percentiles, and the controller's prediction error per frame (median and 95th
percentile of |predicted - measured| frame ms).  Each scene runs in its own subprocess.
With ``--replays N`` the trace is replayed N times back to back by the same loop (its
controller learning on): the traced area is the median of the replays' means (their
range beside it), the other columns pool every replay's frames.

    .venv/bin/python scripts/bench_budget.py [--scenes staircase classroom_animated] [--size 640x480]
        [--fps 15] [--device cpu|cuda:0] [--raster-cache off|on] [--shadow-cache on|off] [--bvh wide|warp]
        [--replays 1]
        [--json out/bench_budget.json]
"""

from __future__ import annotations

import statistics

import numpy as np
from bench_common import BVH_OPTION, ROOT, run_per_scene, wide_bvh_setting

TRACE = ROOT / "scenes" / "traces" / "demo_gaze.csv"
#: The target frame rate option of the budget benchmarks.
FPS_OPTION = ("--fps", {"type": float, "default": 15.0, "help": "target frame rate (default 15)"})


def measure_scene(
    path: str,
    width: int,
    height: int,
    repeats: int,
    fps: float,
    device: str = "cpu",
    raster_cache: str = "off",
    bvh: str = "wide",
    shadow_cache: str = "on",
    replays: int = 1,
) -> dict:
    """Raster-only median (every frame drawn whole) and ``replays`` budgeted replays of the
    trace for one scene (``raster_cache`` "on": the still view's raster layer kept across
    frames, as the replay command does by default; ``shadow_cache`` "on": its primary
    shadows too, likewise)."""
    from gaze.factory import open_source
    from warp_hybrid.renderer import RenderSettings
    from warp_hybrid.replay.loop import AdaptiveLoop, LoopSettings
    from warp_hybrid.replay.run import SteadyGaze
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    budget = 1000.0 / fps
    source = open_scene_source(path)
    raster = RenderSettings(width=width, height=height, mode="raster", device=device)
    with AdaptiveLoop(source, raster, LoopSettings(fps=fps)) as loop:
        gaze = SteadyGaze(open_source("fixed:0.5,0.5"))
        loop.renderer.warm_up(loop.camera)
        raster_ms = statistics.median(loop.step(0.0, gaze.sample(0.0)).frame_ms for _ in range(max(repeats, 3)))
    hybrid = RenderSettings(
        width=width,
        height=height,
        mode="hybrid",
        device=device,
        cache_raster=raster_cache == "on",
        cache_shadows=shadow_cache == "on",
        wide_bvh=wide_bvh_setting(bvh),
    )
    frames_ms, replay_traced, errors = [], [], []
    with open_source(f"trace:{TRACE}") as trace, AdaptiveLoop(source, hybrid, LoopSettings(fps=fps)) as loop:
        gaze = SteadyGaze(trace)
        loop.renderer.warm_up(loop.camera)
        for _ in range(3):
            loop.step(0.0, gaze.sample(0.0))
        frames = int(round(trace.duration * fps))
        for _ in range(max(replays, 1)):
            traced = []
            for i in range(frames):
                t = i / fps
                f = loop.step(t, gaze.sample(t))
                frames_ms.append(f.frame_ms)
                traced.append(f.traced_fraction)
                if f.plan is not None:
                    errors.append(abs(f.plan.predicted_frame_ms - f.frame_ms))
            replay_traced.append(float(np.mean(traced) * 100.0))
    ms = np.asarray(frames_ms)
    return {
        "triangles": source.scene_at(None).triangle_count,
        "budget_ms": budget,
        "raster_ms": raster_ms,
        "feasible": raster_ms <= budget,
        "frames": len(ms),
        "within_pct": float(np.mean(ms <= budget) * 100.0),
        "within_10_pct": float(np.mean(ms <= 1.1 * budget) * 100.0),
        "traced_pct": float(np.median(replay_traced)),
        "traced_pct_replays": replay_traced,
        "p50_ms": float(np.percentile(ms, 50)),
        "p95_ms": float(np.percentile(ms, 95)),
        "prediction_error_p50_ms": float(np.percentile(errors, 50)) if errors else None,
        "prediction_error_p95_ms": float(np.percentile(errors, 95)) if errors else None,
    }


def main() -> None:
    """Every scene in its own subprocess; print the table."""
    args, width, height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[
            FPS_OPTION,
            ("--device", {"default": "cpu", "help": "Warp device (cpu or cuda:0)"}),
            (
                "--raster-cache",
                {
                    "choices": ("off", "on"),
                    "default": "off",
                    "help": "keep the still view's raster layer across the replay's frames (default off: "
                    "every frame drawn whole)",
                },
            ),
            BVH_OPTION,
            (
                "--shadow-cache",
                {
                    "choices": ("off", "on"),
                    "default": "on",
                    "help": "with --raster-cache on, keep the still view's primary shadows across frames (default on; "
                    "the images are the same)",
                },
            ),
            ("--replays", {"type": int, "default": 1, "help": "replays of the trace per scene (default 1)"}),
        ],
    )
    fps = args.fps
    print(
        "| scene | triangles | raster ms | feasible | within budget | within +10% | traced area | p50 ms | p95 ms "
        "| prediction error p50/p95 ms |" + (" traced area, replays |" if args.replays > 1 else "")
    )
    print("|---|---|---|---|---|---|---|---|---|---|" + ("---|" if args.replays > 1 else ""))
    for name, r in results.items():
        err = r["prediction_error_p50_ms"]
        err_text = f"{err:.1f} / {r['prediction_error_p95_ms']:.1f}" if err is not None else "-"
        spread = r["traced_pct_replays"]
        spread_text = f" {min(spread):.1f}-{max(spread):.1f}% |" if args.replays > 1 else ""
        print(
            f"| {name} | {r['triangles']} | {r['raster_ms']:.1f} | {'yes' if r['feasible'] else 'no'} "
            f"| {r['within_pct']:.0f}% | {r['within_10_pct']:.0f}% | {r['traced_pct']:.1f}% "
            f"| {r['p50_ms']:.1f} | {r['p95_ms']:.1f} | {err_text} |{spread_text}"
        )
    cache = "raster layer kept across still frames" if args.raster_cache == "on" else "every frame drawn whole"
    if args.raster_cache == "on":
        cache += ", their primary shadows too" if args.shadow_cache == "on" else ", the shadows traced every frame"
    replayed = f", replayed {args.replays} times (traced area: the median replay)" if args.replays > 1 else ""
    print(f"\n{width}x{height}, {fps:g} FPS (budget {1000.0 / fps:.1f} ms), the shipped 5 s trace{replayed}, {cache}")
    if args.json:
        import json
        from pathlib import Path

        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
