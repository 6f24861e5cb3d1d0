"""A per-kernel profile of one frame: the time of every kernel and host piece, per launch
and per thread (``launch_profile.LaunchProfile`` attached to the renderer's launcher).

    .venv/bin/python scripts/profile_frame.py SCENE [--mode raster|hybrid|full] [--size 640x480]
        [--frames 5] [--window 0.25] [--threads N] [--raster-cache] [--shadow-maps] [--json out/profile.json]

Renders a warm-up frame, then ``--frames`` frames with the profile attached, and prints,
slowest first, each kernel's launches per frame, its wall time per frame (the busiest
thread's time), its CPU time over all threads and the thread balance (mean over busiest
piece); then the frame's stages and the host time no kernel accounts for.  With
``--raster-cache`` (hybrid mode) the still view's raster layer is kept, so the profiled
frames are the kept frames of a gaze replay over a still camera (the gaze fixed at the
centre): what the budget loop's traced window is left with.  ``--shadow-maps`` shadows the
raster layer with shadow maps (their pass and the lighting kernel's shadowed variant).
A profiled pass is timed band by band and so waited for: the profiled frame does not run
a pass on beside the next one's Python (``Launcher.overlapping``), so its host time is
what an unprofiled frame overlaps.
"""

from __future__ import annotations

import argparse
import statistics

import bench_common  # noqa: F401  (puts the checkout on sys.path)


def main() -> None:
    """Profile and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--mode", default="raster", choices=("raster", "hybrid", "full"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--window", type=float, default=0.25)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--raster-cache", action="store_true", help="keep the still view's raster layer (kept frames)")
    ap.add_argument("--shadow-maps", action="store_true", help="shadow the raster layer with shadow maps")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    from warp_hybrid.launch_profile import LaunchProfile
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    width, height = (int(v) for v in args.size.split("x"))
    scene = open_scene_source(args.scene).scene_at(None)
    camera = scene.cameras[0]
    settings = RenderSettings(
        width=width,
        height=height,
        mode=args.mode,
        window_fraction=args.window,
        threads=args.threads,
        cache_raster=args.raster_cache,
        shadow_maps=args.shadow_maps,
    )
    with Renderer(scene, settings) as r:
        r.warm_up(camera)
        profile = LaunchProfile()
        r.launcher.profile = profile
        frames = [r.render(camera).stats for _ in range(args.frames)]
        r.launcher.profile = None
        threads = r.launcher.threads
    rows = profile.rows(args.frames)
    frame_ms = statistics.median(f["frame_ms"] for f in frames)
    kept = ", raster layer kept" if args.raster_cache else ""
    print(f"{args.scene}: --mode {args.mode}, {width}x{height}, {threads} threads, {args.frames} frames{kept}")
    print("| kernel | launches/frame | wall ms/frame | thread CPU ms/frame | balance |")
    print("|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['kernel']} | {row['launches']:.0f} | {row['wall_ms']:.2f} | {row['cpu_ms']:.2f} | "
            f"{row['balance']:.2f} |"
        )
    kernel_ms = sum(float(row["wall_ms"]) for row in rows)
    stages = {k: statistics.median(f["stages_ms"].get(k, 0.0) for f in frames) for k in frames[0]["stages_ms"]}
    print("\nstages (median ms): " + ", ".join(f"{k} {v:.1f}" for k, v in stages.items()))
    print(
        f"frame {frame_ms:.1f} ms; kernels {kernel_ms:.1f} ms; host time outside kernels {frame_ms - kernel_ms:.1f} ms"
    )
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, {"frame_ms": frame_ms, "kernels": rows, "stages_ms": stages})


if __name__ == "__main__":
    main()
