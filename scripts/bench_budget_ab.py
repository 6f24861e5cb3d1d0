"""One switch of the adaptive loop on and off, side by side: the traced area each gets at 15 FPS.

For each shared scene at 640x480, two ``replay.loop.AdaptiveLoop``s over it, one with the
boolean ``RenderSettings`` field ``--setting`` on and one with it off (both keeping the
still view's raster layer unless ``--raster-cache off``), replay the shipped gaze trace
(``scenes/traces/demo_gaze.csv``) with the real clock, their frames interleaved: each
gaze sample is drawn by one loop and then by the other, the order alternating, so a
machine whose speed drifts by 20% between two runs minutes apart (the two-core machines
this runs on) slows both alike and the ratio of their traced areas stays meaningful.
Each loop's controller sees only its own frames.  Reports per loop the mean traced area
(% of the screen, the paper's figure), the median frame time and the frames within the
budget, and the ratio of the traced areas.  Each scene runs in its own subprocess.

    .venv/bin/python scripts/bench_budget_ab.py --setting cache_shadows [--scenes staircase classroom]
        [--fps 15] [--raster-cache on|off] [--replays 2] [--json out/bench_budget_ab.json]
"""

from __future__ import annotations

import dataclasses

import numpy as np
from bench_budget import FPS_OPTION, TRACE
from bench_common import run_per_scene


def measure_scene(
    path: str, width: int, height: int, repeats: int, setting: str, fps: float, raster_cache: str, replays: int
) -> dict:
    """The two interleaved loops over one scene (module docstring); ``repeats`` is unused."""
    from gaze.factory import open_source
    from warp_hybrid.renderer import RenderSettings
    from warp_hybrid.replay.loop import AdaptiveLoop, LoopSettings
    from warp_hybrid.replay.run import SteadyGaze
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    names = {f.name for f in dataclasses.fields(RenderSettings)}
    if setting not in names or not isinstance(getattr(RenderSettings(), setting), bool):
        raise SystemExit(f"--setting must name a boolean RenderSettings field, got {setting!r}")
    init_warp()
    budget = 1000.0 / fps
    base = RenderSettings(width=width, height=height, mode="hybrid", cache_raster=raster_cache == "on")
    loops = {
        state: AdaptiveLoop(
            open_scene_source(path), dataclasses.replace(base, **{setting: state == "on"}), LoopSettings(fps=fps)
        )
        for state in ("on", "off")
    }
    traced: dict[str, list[float]] = {state: [] for state in loops}
    frame_ms: dict[str, list[float]] = {state: [] for state in loops}
    try:
        with open_source(f"trace:{TRACE}") as trace:
            gaze = SteadyGaze(trace)
            for loop in loops.values():
                loop.renderer.warm_up(loop.camera)
                for _ in range(3):
                    loop.step(0.0, gaze.sample(0.0))
            frames = int(round(trace.duration * fps))
            for k in range(max(replays, 1) * frames):
                t = (k % frames) / fps
                sample = gaze.sample(t)
                for state in ("on", "off") if k % 2 == 0 else ("off", "on"):
                    f = loops[state].step(t, sample)
                    traced[state].append(f.traced_fraction)
                    frame_ms[state].append(f.frame_ms)
    finally:
        for loop in loops.values():
            loop.close()
    out: dict = {"budget_ms": budget}
    for state in loops:
        ms = np.asarray(frame_ms[state])
        out[state] = {
            "traced_pct": float(np.mean(traced[state]) * 100.0),
            "p50_ms": float(np.median(ms)),
            "within_pct": float(np.mean(ms <= budget) * 100.0),
        }
    out["traced_ratio"] = out["on"]["traced_pct"] / max(out["off"]["traced_pct"], 1e-9)
    return out


def main() -> None:
    """Every scene in its own subprocess; print the table."""
    args, width, height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[
            ("--setting", {"required": True, "help": "a boolean RenderSettings field, e.g. cache_shadows"}),
            FPS_OPTION,
            (
                "--raster-cache",
                {"choices": ("off", "on"), "default": "on", "help": "keep the still view's raster layer (default on)"},
            ),
            ("--replays", {"type": int, "default": 2, "help": "replays of the trace per loop (default 2)"}),
        ],
    )
    s = args.setting
    print(
        f"| scene | traced area, {s} on | traced area, {s} off | on / off | p50 ms on / off | within budget on / off |"
    )
    print("|---|---|---|---|---|---|")
    for name, r in results.items():
        on, off = r["on"], r["off"]
        print(
            f"| {name} | {on['traced_pct']:.1f}% | {off['traced_pct']:.1f}% | {r['traced_ratio']:.2f}x "
            f"| {on['p50_ms']:.1f} / {off['p50_ms']:.1f} | {on['within_pct']:.0f}% / {off['within_pct']:.0f}% |"
        )
    print(
        f"\n{width}x{height}, {args.fps:g} FPS (budget {1000.0 / args.fps:.1f} ms), the shipped 5 s trace replayed "
        f"{args.replays} times by each loop, frames interleaved"
    )
    if args.json:
        import json
        from pathlib import Path

        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
