"""Host cost of evaluating a USD scene at a new time (``UsdSceneSource.scene_at``).

A replay loop asks the source for the scene at a new time every frame.  For each scene:
the first call (``first_ms``: traversal, triangulation, materials, textures) and the
median of the next calls (``update_ms``, 20 by default): at distinct times spread over
the time range for the animated layers (the shared classroom_animated and
cornell_box_animated, and scenes/textured_animated.usda), and alternating between two
times for the static staircase.  Also the share of calls that returned the previous
call's ``points`` array itself (``same_points``: the device upload skips the copy).
The scenes run one after another in this process.

    .venv/bin/python scripts/bench_scene_update.py [--scenes classroom_animated staircase] [--calls 20]
        [--json out/bench_scene_update.json]
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_common import ROOT, manifest_scenes, shared_scenes_dir

SHARED = ("classroom_animated", "cornell_box_animated", "staircase")
TEXTURED = "textured_animated"


def measure(path: str, calls: int) -> dict:
    """Time the first call and ``calls`` later calls of one scene; returns a JSON-ready dict."""
    import numpy as np

    from warp_hybrid.scene.open import open_scene_source

    t0 = time.perf_counter()
    source = open_scene_source(path)
    previous = source.scene_at(None)
    first_ms = (time.perf_counter() - t0) * 1000.0
    if source.time_range is not None and source.time_range[1] > source.time_range[0]:
        start, end = source.time_range
        times = [float(t) for t in np.linspace(start, end, calls + 1)[1:]]
    else:  # static: two times, alternately
        base = previous.time
        times = [base + (k + 1) % 2 for k in range(calls)]
    runs, same = [], 0
    for t in times:
        t0 = time.perf_counter()
        scene = source.scene_at(t)
        runs.append((time.perf_counter() - t0) * 1000.0)
        same += scene.points is previous.points
        previous = scene
    return {
        "triangles": previous.triangle_count,
        "animated_meshes": sum(r.animated for r in previous.meshes),
        "first_ms": first_ms,
        "update_ms": statistics.median(runs),
        "same_points": same / len(times),
        "calls": len(times),
    }


def main() -> None:
    """Measure the scenes and print a markdown table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=None, help=f"names (default: {TEXTURED} {' '.join(SHARED)})")
    ap.add_argument("--calls", type=int, default=20, help="calls after the first (default 20)")
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    wanted = args.scenes or [TEXTURED, *SHARED]
    paths = {}
    if TEXTURED in wanted:
        paths[TEXTURED] = str(ROOT / "scenes" / "textured_animated.usda")
    shared = [n for n in wanted if n != TEXTURED]
    if shared:
        if (shared_scenes_dir() / "manifest.json").is_file():
            paths.update({e["name"]: e["path"] for e in manifest_scenes(shared)})
        else:
            print(f"shared scenes not found at {shared_scenes_dir()}; measuring {TEXTURED} only")
    results = {name: measure(path, args.calls) for name, path in paths.items()}
    print("| scene | triangles | animated meshes | first call ms | scene_at(new t) ms | same points array |")
    print("|---|---|---|---|---|---|")
    for name, r in results.items():
        print(
            f"| {name} | {r['triangles']} | {r['animated_meshes']} | {r['first_ms']:.1f} | {r['update_ms']:.2f} "
            f"| {100 * r['same_points']:.0f}% |"
        )
    print(f"\nmedian of {args.calls} calls after the first")
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, {"calls": args.calls, "scenes": results})


if __name__ == "__main__":
    main()
