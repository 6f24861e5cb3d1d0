"""The mid-resolution ring's frame time: hybrid windows with and without ``--ring``,
rendered interleaved (one frame of each configuration per round, so the machine's load
hits them alike), medians and minima per configuration with the trace, upsample, focus
and compose stages.

    .venv/bin/python scripts/bench_ring.py SCENE [--size 320x240] [--gaze 0.35,0.55]
        [--rounds 15] [--exposure 3.43]

Errors are deterministic and come from ``warp-hybrid bench ... [--ring]``; this script
only times (one process, one configuration at a time, never two timed things at once).
"""

from __future__ import annotations

import argparse
import statistics
import time

import bench_common  # noqa: F401  (puts the checkout on sys.path)

CONFIGS = {
    "hybrid 10%": dict(window_fraction=0.1),
    "hybrid 10% --ring": dict(window_fraction=0.1, ring=True),
    "hybrid 10% --ring --ring-scale 1.5": dict(window_fraction=0.1, ring=True, ring_scale=1.5),
    "hybrid 10% --ring --ring-step 4": dict(window_fraction=0.1, ring=True, ring_step=4),
    "hybrid 25%": dict(window_fraction=0.25),
    "hybrid 25% --ring": dict(window_fraction=0.25, ring=True),
}
STAGES = ("trace_shadow", "trace_secondary", "upsample", "focus", "compose")


def main() -> None:
    """Time every configuration and print one line each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--gaze", default="0.35,0.55")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--exposure", type=float, default=3.43, help="fixed exposure in stops (no metering pass)")
    args = ap.parse_args()
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.device import DeviceScene
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    width, height = (int(v) for v in args.size.split("x"))
    gaze = tuple(float(v) for v in args.gaze.split(","))
    scene = open_scene_source(args.scene, screen=(width, height)).scene_at(None)
    camera = scene.cameras[0]
    shared = DeviceScene(scene, "cpu")
    renderers = {}
    for name, extra in CONFIGS.items():
        r = Renderer(shared, RenderSettings(width=width, height=height, exposure_ev=args.exposure, **extra))
        r.warm_up(camera)
        renderers[name] = (r, r.default_window(gaze))
    times: dict[str, list[float]] = {k: [] for k in CONFIGS}
    stages: dict[str, list[dict[str, float]]] = {k: [] for k in CONFIGS}
    for _ in range(args.rounds):
        for name, (r, window) in renderers.items():
            start = time.perf_counter()
            frame = r.render(camera, window)
            times[name].append((time.perf_counter() - start) * 1000.0)
            stages[name].append(frame.stats["stages_ms"])
    for name in CONFIGS:
        medians = {k: statistics.median(s.get(k, 0.0) for s in stages[name]) for k in STAGES}
        detail = " ".join(f"{k} {v:.1f}" for k, v in medians.items())
        print(f"{name:38s} median {statistics.median(times[name]):6.1f} ms (min {min(times[name]):6.1f})  {detail}")
    for r, _ in renderers.values():
        r.close()


if __name__ == "__main__":
    main()
