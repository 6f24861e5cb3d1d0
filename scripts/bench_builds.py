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

With ``--threads N [N ...]`` every build runs once per thread count (a configuration
each, build by build, its thread counts in the order given), so one build against
itself measures how its passes scale with threads in the same phases of the machine
(the target "two threads >= 1.8x one on every pass over 2 ms"): the stage table (every
frame's ``stats["stages_ms"]``) and, with ``--profile``, the kernel table give
each configuration's median ms and the first configuration's over its own, the median
over turns of the two in the same round (a kernel that only one configuration runs, such
as the one-thread coverage pass, has no ratio).

    git worktree add /tmp/base HEAD~3
    .venv/bin/python scripts/bench_builds.py /tmp/base . [--scenes suzanne_metal_env glass_dragon]
        [--turns 40] [--frames 10] [--workers 2] [--profile] [--mode raster] [--size 640x480] [--json out/builds.json]
    .venv/bin/python scripts/bench_builds.py . --threads 1 2 --scenes glass_dragon --profile --turns 20
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
from typing import NamedTuple

READY = "ready"


def worker(build: str, scene_path: str, mode: str, width: int, height: int, threads: int) -> None:
    """Serve turns on stdin: a line ``FRAMES PROFILE`` renders that many frames and prints
    their wall ms, each stage's median ms over them (and, with PROFILE 1, each kernel's
    wall and CPU ms a frame) as JSON.  ``threads`` 0: the launcher's own count."""
    import time

    from warp_hybrid.launch_profile import LaunchProfile
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(scene_path).scene_at(None)
    camera = scene.cameras[0]
    settings = RenderSettings(width=width, height=height, mode=mode, threads=threads or None)
    with Renderer(scene, settings) as renderer:
        renderer.warm_up(camera)
        for _ in range(5):
            renderer.render(camera, host_copies=False)
        print(READY, flush=True)
        for line in sys.stdin:
            frames, profiled = (int(v) for v in line.split())
            profile = LaunchProfile() if profiled else None
            renderer.launcher.profile = profile
            times = []
            stages: dict[str, list[float]] = {}
            for _ in range(frames):
                start = time.perf_counter()
                result = renderer.render(camera, host_copies=False)
                times.append((time.perf_counter() - start) * 1000.0)
                for stage, ms in result.stats["stages_ms"].items():
                    stages.setdefault(stage, []).append(ms)
            renderer.launcher.profile = None
            out: dict = {"frames": times, "stages": {k: statistics.median(v) for k, v in stages.items()}}
            if profile is not None:
                out["kernels"] = {row["kernel"]: [row["wall_ms"], row["cpu_ms"]] for row in profile.rows(frames)}
            print(json.dumps(out), flush=True)


class Config(NamedTuple):
    """One configuration measured: a build (a checkout's path) at a thread count (0: the
    launcher's own)."""

    build: str
    threads: int

    @property
    def label(self) -> str:
        """The build's folder name, and its thread count where one was given."""
        name = Path(self.build).name or self.build
        return f"{name}, {self.threads} thread{'s' if self.threads > 1 else ''}" if self.threads else name


def _start(config: Config, scene_path: str, args: argparse.Namespace) -> subprocess.Popen:
    """A worker process for ``config`` on ``scene_path``, once it is warm."""
    width, height = (int(v) for v in args.size.split("x"))
    proc = subprocess.Popen(
        [sys.executable, __file__, "--worker", config.build, scene_path, args.mode, str(width), str(height)]
        + [str(config.threads)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=config.build,
    )
    for line in proc.stdout:
        if line.strip() == READY:
            return proc
    raise SystemExit(f"the worker for {config.label} on {scene_path} ended before it was warm (see its output above)")


def _first_over_this(turns: list[dict[str, float]], name: str, c: int) -> float:
    """The median over turns of configuration 0's ms of ``name`` over configuration
    ``c``'s in the same turn (nan where either never ran it)."""
    ratios = [t[0][name] / t[c][name] for t in turns if name in t.get(0, {}) and name in t.get(c, {}) and t[c][name]]
    return statistics.median(ratios) if ratios else float("nan")


def measure_scene(scene_path: str, configs: list[Config], args: argparse.Namespace) -> dict:
    """Every configuration's workers taking turns on one scene (module docstring)."""
    slots = [(c, _start(config, scene_path, args)) for _ in range(args.workers) for c, config in enumerate(configs)]
    frames: list[list[float]] = [[] for _ in configs]
    turns: list[list[float]] = [[] for _ in configs]
    # per round: configuration -> stage or kernel -> its ms (median over the round's workers)
    stage_rounds: list[dict[int, dict[str, float]]] = []
    kernel_rounds: list[dict[int, dict[str, float]]] = []
    kernels: list[dict[str, list[list[float]]]] = [{} for _ in configs]
    try:
        for k in range(args.turns):
            order = slots if k % 2 == 0 else slots[::-1]
            medians: dict[int, list[float]] = {}
            stages: dict[int, dict[str, list[float]]] = {}
            walls: dict[int, dict[str, list[float]]] = {}
            for c, proc in order:
                proc.stdin.write(f"{args.frames} {int(args.profile)}\n")
                proc.stdin.flush()
                out = json.loads(proc.stdout.readline())
                frames[c] += out["frames"]
                medians.setdefault(c, []).append(statistics.median(out["frames"]))
                for name, ms in out["stages"].items():
                    stages.setdefault(c, {}).setdefault(name, []).append(ms)
                for name, times in out.get("kernels", {}).items():
                    kernels[c].setdefault(name, []).append(times)
                    walls.setdefault(c, {}).setdefault(name, []).append(times[0])
            for c in range(len(configs)):
                turns[c].append(statistics.median(medians[c]) / statistics.median(medians[0]))
            stage_rounds.append({c: {n: statistics.median(v) for n, v in d.items()} for c, d in stages.items()})
            kernel_rounds.append({c: {n: statistics.median(v) for n, v in d.items()} for c, d in walls.items()})
    finally:
        for _, proc in slots:
            proc.stdin.close()
            proc.wait()
    return {
        config.label: {
            "build": config.build,
            "threads": config.threads,
            "frame_ms": statistics.median(frames[c]),
            "ratio": statistics.median(turns[c]),
            "stages": {
                name: {
                    "ms": statistics.median(r[c][name] for r in stage_rounds if name in r.get(c, {})),
                    "first_over_this": _first_over_this(stage_rounds, name, c),
                }
                for name in stage_rounds[0].get(c, {})
            },
            "kernels": {
                name: {
                    "wall_ms": statistics.median(t[0] for t in times),
                    "cpu_ms": statistics.median(t[1] for t in times),
                    "first_over_this": _first_over_this(kernel_rounds, name, c),
                }
                for name, times in kernels[c].items()
            },
        }
        for c, config in enumerate(configs)
    }


def _print_table(result: dict, part: str, value: str, title: str, ratios: bool = True) -> None:
    """One markdown table of ``part`` ("stages" or "kernels"): each configuration's
    ``value`` and (``ratios``), beside every configuration after the first, the first's
    wall ms over its own (median of turns), rows slowest first in the first configuration."""
    labels = list(result)
    first = result[labels[0]][part]
    names = sorted({n for r in result.values() for n in r[part]}, key=lambda n: -first.get(n, {}).get(value, 0.0))
    compared = labels[1:] if ratios else []
    heads = [f"{title}, {label}" for label in labels] + [f"{labels[0]} over {label}" for label in compared]
    print(f"\n| {part[:-1]} | " + " | ".join(heads) + " |")
    print("|---|" + "---|" * len(heads))
    for name in names:
        cells = [f"{result[label][part].get(name, {}).get(value, float('nan')):.3f}" for label in labels]
        cells += [
            f"{result[label][part].get(name, {}).get('first_over_this', float('nan')):.2f}x" for label in compared
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")


def main() -> None:
    """Parse the arguments, run every scene, print the tables."""
    from bench_common import manifest_scenes

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("builds", nargs="+", help="checkouts to compare, the first the baseline")
    ap.add_argument("--scenes", nargs="*", default=["suzanne_metal_env", "glass_dragon"])
    ap.add_argument("--turns", type=int, default=40)
    ap.add_argument("--frames", type=int, default=10, help="frames a turn")
    ap.add_argument("--workers", type=int, default=2, help="processes a build")
    ap.add_argument(
        "--threads", type=int, nargs="+", default=[0], help="thread counts, each a configuration of every build"
    )
    ap.add_argument("--profile", action="store_true", help="each kernel's wall and thread CPU ms a frame")
    ap.add_argument("--mode", default="raster", choices=("raster", "hybrid", "full"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    builds = [str(Path(b).resolve()) for b in args.builds]
    for build in builds:
        if not (Path(build) / "warp_hybrid").is_dir():
            raise SystemExit(f"{build}: not a checkout of this project (no warp_hybrid/)")
    if any(t < 1 for t in args.threads) and args.threads != [0]:
        raise SystemExit(f"--threads {args.threads}: thread counts are 1 or more")
    configs = [Config(build, threads) for build in builds for threads in args.threads]
    if len({c.label for c in configs}) < len(configs):
        raise SystemExit("two configurations share a label (the same build, or two builds in folders of one name)")
    results = {}
    for entry in manifest_scenes(args.scenes):
        result = results[entry["name"]] = measure_scene(entry["path"], configs, args)
        print(
            f"\n{entry['name']}: {args.mode}, {args.size}, {args.turns} turns of {args.frames} frames, "
            f"{args.workers} processes a configuration"
        )
        print("| build | frame ms (median) | against the first (median of turns) |")
        print("|---|---|---|")
        for label, r in result.items():
            print(f"| {label} | {r['frame_ms']:.3f} | {r['ratio']:.4f} |")
        _print_table(result, "stages", "ms", "ms")
        if args.profile:
            _print_table(result, "kernels", "wall_ms", "wall ms")
            _print_table(result, "kernels", "cpu_ms", "thread CPU ms", ratios=False)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--worker"]:
        worker(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), int(sys.argv[6]), int(sys.argv[7]))
    else:
        main()
