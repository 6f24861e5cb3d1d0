"""The raster frame of several builds of this project side by side, in warm processes taking turns.

Each build (a checkout: this one, or ``git worktree add /tmp/base REV`` of another commit)
runs in ``--workers`` worker processes of its own per scene, each with a warm renderer
(640x480 by default, the launcher's threads); the workers take turns of ``--frames``
frames (``render(..., host_copies=False)``, as the replay loop and the viewer render),
the order of the builds reversed every other turn, for ``--turns`` rounds.  So on a
machine whose speed drifts by tens of percent within minutes (the two-vCPU machines this
runs on) every build sees the same phases, and a change of a few percent shows where
runs one after the other would bury it.  A worker that is not rendering waits on its
pipe (its band threads go to sleep).  Reports per build the median frame, the median over
turns of its turn's median against the first build's in the same round, and with
``--profile`` each kernel's wall and thread CPU ms a frame (``LaunchProfile``; a profiled
pass is timed band by band and so waited for, so its frames leave out a pass running on
beside the next one's Python, ``Launcher.overlapping``: compare frame times without it).
The workers run one at a time: never two timed things at once.

    git worktree add /tmp/base HEAD~3
    .venv/bin/python scripts/bench_builds.py /tmp/base . [--scenes suzanne_metal_env glass_dragon]
        [--turns 40] [--frames 10] [--workers 2] [--profile] [--mode raster] [--size 640x480] [--json out/builds.json]
"""

from __future__ import annotations

import sys

if __name__ == "__main__" and len(sys.argv) > 1 and sys.argv[1] == "--worker":
    # a worker imports the build it was given, not this checkout (``bench_common`` would
    # put this checkout first on the path)
    sys.path.insert(0, sys.argv[2])

import argparse
import json
import os
import statistics
import subprocess
from pathlib import Path

READY = "ready"


def worker(build: str, scene_path: str, mode: str, width: int, height: int) -> None:
    """Serve turns on stdin: a line ``FRAMES PROFILE`` renders that many frames and prints
    their wall ms (and, with PROFILE 1, each kernel's wall and CPU ms a frame) as JSON."""
    import time

    from warp_hybrid.launch_profile import LaunchProfile
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(scene_path).scene_at(None)
    camera = scene.cameras[0]
    with Renderer(scene, RenderSettings(width=width, height=height, mode=mode)) as renderer:
        renderer.warm_up(camera)
        for _ in range(5):
            renderer.render(camera, host_copies=False)
        print(READY, flush=True)
        for line in sys.stdin:
            frames, profiled = (int(v) for v in line.split())
            profile = LaunchProfile() if profiled else None
            renderer.launcher.profile = profile
            times = []
            for _ in range(frames):
                start = time.perf_counter()
                renderer.render(camera, host_copies=False)
                times.append((time.perf_counter() - start) * 1000.0)
            renderer.launcher.profile = None
            out: dict = {"frames": times}
            if profile is not None:
                out["kernels"] = {row["kernel"]: [row["wall_ms"], row["cpu_ms"]] for row in profile.rows(frames)}
            print(json.dumps(out), flush=True)


def _start(build: str, scene_path: str, args: argparse.Namespace) -> subprocess.Popen:
    """A worker process for ``build`` on ``scene_path``, once it is warm."""
    width, height = (int(v) for v in args.size.split("x"))
    proc = subprocess.Popen(
        [sys.executable, __file__, "--worker", build, scene_path, args.mode, str(width), str(height)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=build,
    )
    for line in proc.stdout:
        if line.strip() == READY:
            return proc
    raise SystemExit(f"the worker for {build} on {scene_path} ended before it was warm (see its output above)")


def measure_scene(scene_path: str, builds: list[str], args: argparse.Namespace) -> dict:
    """Every build's workers taking turns on one scene (module docstring)."""
    slots = [(b, _start(build, scene_path, args)) for _ in range(args.workers) for b, build in enumerate(builds)]
    frames: list[list[float]] = [[] for _ in builds]
    turns: list[list[float]] = [[] for _ in builds]
    kernels: list[dict[str, list[list[float]]]] = [{} for _ in builds]
    try:
        for k in range(args.turns):
            order = slots if k % 2 == 0 else slots[::-1]
            medians: dict[int, list[float]] = {}
            for b, proc in order:
                proc.stdin.write(f"{args.frames} {int(args.profile)}\n")
                proc.stdin.flush()
                out = json.loads(proc.stdout.readline())
                frames[b] += out["frames"]
                medians.setdefault(b, []).append(statistics.median(out["frames"]))
                for name, times in out.get("kernels", {}).items():
                    kernels[b].setdefault(name, []).append(times)
            for b in range(len(builds)):
                turns[b].append(statistics.median(medians[b]) / statistics.median(medians[0]))
    finally:
        for _, proc in slots:
            proc.stdin.close()
            proc.wait()
    return {
        build: {
            "frame_ms": statistics.median(frames[b]),
            "ratio": statistics.median(turns[b]),
            "kernels": {
                name: {
                    "wall_ms": statistics.median(t[0] for t in times),
                    "cpu_ms": statistics.median(t[1] for t in times),
                }
                for name, times in kernels[b].items()
            },
        }
        for b, build in enumerate(builds)
    }


def main() -> None:
    """Parse the arguments, run every scene, print the tables."""
    from bench_common import manifest_scenes

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("builds", nargs="+", help="checkouts to compare, the first the baseline")
    ap.add_argument("--scenes", nargs="*", default=["suzanne_metal_env", "glass_dragon"])
    ap.add_argument("--turns", type=int, default=40)
    ap.add_argument("--frames", type=int, default=10, help="frames a turn")
    ap.add_argument("--workers", type=int, default=2, help="processes a build")
    ap.add_argument("--profile", action="store_true", help="each kernel's wall and thread CPU ms a frame")
    ap.add_argument("--mode", default="raster", choices=("raster", "hybrid", "full"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    builds = [str(Path(b).resolve()) for b in args.builds]
    for build in builds:
        if not (Path(build) / "warp_hybrid").is_dir():
            raise SystemExit(f"{build}: not a checkout of this project (no warp_hybrid/)")
    results = {}
    for entry in manifest_scenes(args.scenes):
        result = results[entry["name"]] = measure_scene(entry["path"], builds, args)
        print(
            f"\n{entry['name']}: {args.mode}, {args.size}, {args.turns} turns of {args.frames} frames, "
            f"{args.workers} processes a build"
        )
        print("| build | frame ms (median) | against the first (median of turns) |")
        print("|---|---|---|")
        for build, r in result.items():
            print(f"| {build} | {r['frame_ms']:.3f} | {r['ratio']:.4f} |")
        if args.profile:
            names = sorted(result[builds[0]]["kernels"], key=lambda n: -result[builds[0]]["kernels"][n]["cpu_ms"])
            print("\n| kernel | " + " | ".join(f"thread CPU ms, {Path(b).name}" for b in builds) + " |")
            print("|---|" + "---|" * len(builds))
            for name in names:
                cells = [f"{result[b]['kernels'].get(name, {}).get('cpu_ms', float('nan')):.3f}" for b in builds]
                print(f"| {name} | " + " | ".join(cells) + " |")
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--worker"]:
        worker(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), int(sys.argv[6]))
    else:
        main()
