"""Helpers shared by the benchmark scripts: scene discovery, medians, subprocess runs."""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def shared_scenes_dir() -> Path:
    """``WARP_HYBRID_SHARED_SCENES`` or ``../shared/scenes`` beside the checkout."""
    return Path(os.environ.get("WARP_HYBRID_SHARED_SCENES", ROOT.parent / "shared" / "scenes"))


def manifest_scenes(names: list[str] | None = None) -> list[dict]:
    """Entries of the shared scenes' manifest.json (optionally only ``names``), each
    with an absolute ``path``; exits with a message when the folder is absent."""
    folder = shared_scenes_dir()
    manifest = folder / "manifest.json"
    if not manifest.is_file():
        sys.exit(f"shared scenes not found at {folder} (set WARP_HYBRID_SHARED_SCENES)")
    entries = json.loads(manifest.read_text())["scenes"]
    if names:
        entries = [e for e in entries if e["name"] in names]
    for e in entries:
        e["path"] = str(folder / e["file"])
    return entries


def median_ms(fn: Callable[[], dict[str, float]], repeats: int = 5, warmup: int = 1) -> dict[str, float]:
    """Run ``fn`` (returning ms per stage) ``warmup`` times, then ``repeats`` times;
    return the per-stage medians."""
    for _ in range(warmup):
        fn()
    return _stage_medians([fn() for _ in range(repeats)])


def _stage_medians(runs: Sequence[dict[str, float]]) -> dict[str, float]:
    """Each stage's median over ``runs`` (ms per stage, every run the same stages)."""
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def interleaved_medians(
    fns: Sequence[Callable[[], dict[str, float]]], repeats: int = 5, warmup: int = 2, settle_s: float = 0.005
) -> list[dict[str, float]]:
    """``median_ms`` for several timed things at once, each run in turn: per repeat every
    ``fn`` in turn (in order on even repeats, reversed on odd ones), each run twice back to
    back and its second run kept (threads that a first run woke are awake, as between a
    replay's frames), ``settle_s`` apart (longer than the native band threads spin:
    neither side's idle threads take the cores from the other's run).  A machine whose
    speed drifts over seconds then slows every side alike, so their ratios hold.
    Returns each ``fn``'s per-stage medians, in order."""
    for fn in fns:
        for _ in range(warmup):
            fn()
    runs: list[list[dict[str, float]]] = [[] for _ in fns]
    for r in range(repeats):
        order = range(len(fns)) if r % 2 == 0 else reversed(range(len(fns)))
        for i in order:
            time.sleep(settle_s)
            fns[i]()
            runs[i].append(fns[i]())
    return [_stage_medians(fn_runs) for fn_runs in runs]


def peak_rss_mb() -> float:
    """Peak resident set size of this process in MiB (Linux ru_maxrss is in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


#: The benchmarks' ``--bvh`` option: the tracer's 4-wide BVH copies (the CPU's default)
#: or Warp's own queries, to measure the one against the other.
BVH_OPTION = (
    "--bvh",
    {
        "choices": ("wide", "warp"),
        "default": "wide",
        "help": "the BVH queries of the tracer and the ray-cast primaries: the 4-wide copies (default on the CPU) or Warp's own",
    },
)


def wide_bvh_setting(bvh: str) -> bool | None:
    """``RenderSettings.wide_bvh`` for a ``--bvh`` value (None: the device's default)."""
    return None if bvh == "wide" else False


def run_per_scene(
    description: str,
    script: str,
    measure: Callable[..., dict],
    options: Sequence[tuple[str, dict[str, Any]]] = (),
) -> tuple[argparse.Namespace, int, int, dict[str, dict]]:
    """The shared driver of the scene benchmarks.

    Parses ``--scenes``, ``--size``, ``--repeats``, ``--json`` and the script's own
    ``options`` (flag, ``add_argument`` keywords); run with the hidden ``--one PATH`` it
    measures that scene in this process (``measure(path, width, height, repeats,
    **options)``), prints the JSON and exits; otherwise it runs ``script --one`` once per
    manifest scene in its own subprocess (so peak RSS is per scene), forwarding the
    options, and returns (args, width, height, results by name).  A scene whose
    subprocess fails is reported on stderr and left out.
    """
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--scenes", nargs="*", default=None, help="manifest names (default: all)")
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", default=None, help="also write the results here")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)
    for flag, kwargs in options:
        ap.add_argument(flag, **kwargs)
    args = ap.parse_args()
    extra = {flag.lstrip("-").replace("-", "_"): flag for flag, _ in options}
    width, height = (int(v) for v in args.size.split("x"))
    if args.one:
        values = {name: getattr(args, name) for name in extra}
        print(json.dumps(measure(args.one, width, height, args.repeats, **values)))
        sys.exit(0)
    forwarded = [str(v) for name, flag in extra.items() for v in (flag, getattr(args, name))]
    results = {}
    for entry in manifest_scenes(args.scenes):
        proc = subprocess.run(
            [
                sys.executable,
                script,
                "--one",
                entry["path"],
                "--size",
                args.size,
                "--repeats",
                str(args.repeats),
                *forwarded,
            ],
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0:
            print(f"{entry['name']}: failed\n{proc.stderr[-2000:]}", file=sys.stderr)
            continue
        results[entry["name"]] = json.loads(proc.stdout.strip().splitlines()[-1])
    return args, width, height, results
