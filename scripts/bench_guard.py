"""The budget guard's own cost: one window traced in rings under a deadline never reached
(``trace.guard.GuardedTrace``) against the same window traced as one list (the plain
``Tracer`` pass), alternated frame by frame in one process.

    .venv/bin/python scripts/bench_guard.py [SCENE] [--size 640x480] [--window 0.12] [--frames 15]

``SCENE`` is a path or a shared scene's name (default: the staircase).  The still view's
raster layer is kept (``cache_raster``), so each frame is what a gaze replay pays; prints
the medians of the frame, of tracing (``trace_shadow + trace_secondary``) and of ``focus``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_common import manifest_scenes


def main() -> None:
    """Measure and print."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default="staircase")
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--window", type=float, default=0.12)
    ap.add_argument("--frames", type=int, default=15)
    args = ap.parse_args()
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    path = args.scene if "/" in args.scene or "." in args.scene else manifest_scenes([args.scene])[0]["path"]
    width, height = (int(v) for v in args.size.split("x"))
    scene = open_scene_source(path).scene_at(None)
    camera = scene.cameras[0]
    settings = RenderSettings(width=width, height=height, mode="hybrid", window_fraction=args.window, cache_raster=True)
    stats: dict[str, list[dict]] = {"one list (no deadline)": [], "rings (deadline never reached)": []}
    with Renderer(scene, settings) as r:
        r.warm_up(camera)
        for k in range(args.frames):
            for name, frames in stats.items():
                window = r.default_window((0.5 + 0.002 * k, 0.5))  # the gaze moves: the window is traced again
                deadline = time.perf_counter() + 3600.0 if name.startswith("rings") else None
                frames.append(r.render(camera, window, trace_deadline=deadline).stats)
    print(f"{path}: {width}x{height}, window {args.window:.0%}, medians of {args.frames} frames (ms)")
    print("| tracing | frame | trace_shadow + trace_secondary | focus |")
    print("|---|---|---|---|")
    for name, frames in stats.items():
        trace = [f["stages_ms"].get("trace_shadow", 0.0) + f["stages_ms"].get("trace_secondary", 0.0) for f in frames]
        print(
            f"| {name} | {statistics.median(f['frame_ms'] for f in frames):.1f} | {statistics.median(trace):.1f} | "
            f"{statistics.median(f['stages_ms']['focus'] for f in frames):.2f} |"
        )


if __name__ == "__main__":
    main()
