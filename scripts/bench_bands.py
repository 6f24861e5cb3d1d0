"""Native band threads against the Python pool: the same frames, interleaved in one process.

For each shared scene at 640x480, one renderer per mode renders a warm-up frame, then
``--repeats`` frames with the passes' bands on the native band threads
(``band_pool``) and as many on the Python pool (``Launcher.native_bands = False``),
alternating frame by frame (the order swapped every other pair), so both see the same
machine: this machine's timings move by up to 2x between runs minutes apart, far more
than what the launch layer changes.  The modes: ``raster``, ``kept`` (hybrid with a 25%
window and the still view's raster layer kept: a gaze replay's frames, the tracer's
bands under no deadline) and ``full``.  Before each Python-pool frame the band threads
are told to sleep (as the launcher does before any Python-pool work), so they do not
spin on the cores it needs; a native frame after one therefore starts by waking them.
Frames are timed as the replay loop renders them (``host_copies=False``).

    .venv/bin/python scripts/bench_bands.py [--scenes staircase classroom] [--size 640x480]
        [--repeats 20] [--modes raster,kept,full] [--json out/bench_bands.json]
"""

from __future__ import annotations

import statistics
import time

from bench_common import run_per_scene

MODES = ("raster", "kept", "full")


def measure_scene(path: str, width: int, height: int, repeats: int, modes: str) -> dict:
    """Per mode (``modes``: comma-separated) the median frame ms with the native band
    threads and with the Python pool, frames interleaved."""
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(path).scene_at(None)
    camera = scene.cameras[0]
    out = {}
    for mode in modes.split(","):
        if mode not in MODES:
            raise SystemExit(f"unknown mode {mode!r} (choose from {', '.join(MODES)})")
        settings = RenderSettings(
            width=width,
            height=height,
            mode="hybrid" if mode == "kept" else mode,
            window_fraction=0.25,
            cache_raster=mode == "kept",
        )
        with Renderer(scene, settings) as renderer:
            launcher = renderer.launcher
            if not launcher.native_bands:
                return {"error": "no native band threads here"}
            renderer.warm_up(camera)
            frames: dict[bool, list[float]] = {True: [], False: []}
            for k in range(repeats):
                for native in (True, False) if k % 2 else (False, True):
                    launcher.native_bands = native
                    start = time.perf_counter()
                    renderer.render(camera, host_copies=False)
                    frames[native].append((time.perf_counter() - start) * 1000.0)
            launcher.native_bands = True
        out[mode] = {"python_ms": statistics.median(frames[False]), "native_ms": statistics.median(frames[True])}
    return out


def main() -> None:
    """Measure every scene in its own subprocess and print the table."""
    modes_option = ("--modes", {"default": ",".join(MODES), "help": "comma-separated: raster, kept, full"})
    args, width, height, results = run_per_scene(
        __doc__.splitlines()[0], __file__, measure_scene, options=[modes_option]
    )
    print("| scene | mode | Python pool ms | native band threads ms | ratio |")
    print("|---|---|---|---|---|")
    for name, per_mode in results.items():
        if "error" in per_mode:
            print(f"| {name} | - | {per_mode['error']} | | |")
            continue
        for mode, r in per_mode.items():
            ratio = r["python_ms"] / r["native_ms"] if r["native_ms"] > 0 else float("nan")
            print(f"| {name} | {mode} | {r['python_ms']:.1f} | {r['native_ms']:.1f} | {ratio:.2f}x |")
    print(f"\n{width}x{height}, medians of {args.repeats} frames each, interleaved")
    if args.json:
        import json

        with open(args.json, "w") as f:
            json.dump({"size": [width, height], "scenes": results}, f, indent=2)


if __name__ == "__main__":
    main()
