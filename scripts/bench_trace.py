"""The paper's Table 1 for our scenes: raster (DS), full ray tracing (RT) and hybrid (HRT).

For each scene at 640x480 (median of 5 after a warm-up): ms per stage and frames per
second for ``--mode raster``, ``--mode full`` and ``--mode hybrid`` with a 25% circular
window centred on the screen; Mrays/s per ray type (shadow, and secondary =
reflection + refraction) in full mode; and full-mode tracing with 1 thread vs all
threads, to check the launch layer's scaling.  Each scene runs in its own subprocess.

    .venv/bin/python scripts/bench_trace.py [--scenes staircase glass_dragon] [--size 640x480]
        [--repeats 5] [--device cpu|cuda:0] [--bvh wide|warp] [--json out/bench_trace.json]
"""

from __future__ import annotations

from bench_common import BVH_OPTION, median_ms, run_per_scene, wide_bvh_setting

TRACE_STAGES = ("trace_shadow", "trace_secondary")


def measure_scene(path: str, width: int, height: int, repeats: int, device: str = "cpu", bvh: str = "wide") -> dict:
    """All modes of one scene in this process on ``device``; returns a JSON-ready dict."""
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(path).scene_at(None)
    camera = scene.cameras[0]
    out: dict = {"triangles": scene.triangle_count}
    configs = {
        "raster": ("raster", None),
        "full": ("full", None),
        "hybrid": ("hybrid", None),
        "full_1thread": ("full", 1),
    }
    for name, (mode, threads) in configs.items():
        settings = RenderSettings(
            width=width,
            height=height,
            mode=mode,
            window_fraction=0.25,
            threads=threads,
            device=device,
            wide_bvh=wide_bvh_setting(bvh),
        )
        with Renderer(scene, settings) as r:
            last: dict = {}

            def frame() -> dict[str, float]:
                f = r.render(camera)
                last.update(f.stats)
                return {**f.stats["stages_ms"], "frame": f.stats["frame_ms"]}

            stages = median_ms(frame, repeats)
            out[name] = {
                "stages_ms": stages,
                "fps": 1000.0 / stages["frame"],
                "rays": last.get("rays"),
                "threads": r.launcher.threads,
                "effects": last["effects"],
            }
    full = out["full"]
    rays = full["rays"] or {}
    shadow_ms = full["stages_ms"].get("trace_shadow", 0.0)
    secondary_ms = full["stages_ms"].get("trace_secondary", 0.0)
    out["mrays_per_s"] = {
        "shadow": rays.get("shadow", 0) / shadow_ms / 1000.0 if shadow_ms else 0.0,
        "secondary": (rays.get("reflection", 0) + rays.get("refraction", 0)) / secondary_ms / 1000.0
        if secondary_ms
        else 0.0,
    }
    trace_ms = {k: sum(out[k]["stages_ms"].get(s, 0.0) for s in TRACE_STAGES) for k in ("full", "full_1thread")}
    out["trace_speedup_threads"] = trace_ms["full_1thread"] / trace_ms["full"] if trace_ms["full"] else 0.0
    out["hrt_vs_rt"] = out["full"]["stages_ms"]["frame"] / out["hybrid"]["stages_ms"]["frame"]
    return out


def main() -> None:
    """Run the benchmark and print the tables."""
    args, width, height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[("--device", {"default": "cpu", "help": "Warp device (cpu or cuda:0)"}), BVH_OPTION],
    )
    print(
        "| scene | triangles | DS fps | RT fps | HRT fps (25%) | HRT vs RT | shadow Mrays/s | secondary Mrays/s | trace 2 vs 1 thread |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, r in results.items():
        print(
            f"| {name} | {r['triangles']} | {r['raster']['fps']:.1f} | {r['full']['fps']:.1f} | {r['hybrid']['fps']:.1f} | "
            f"{r['hrt_vs_rt']:.2f}x | {r['mrays_per_s']['shadow']:.2f} | {r['mrays_per_s']['secondary']:.2f} | "
            f"{r['trace_speedup_threads']:.2f}x |"
        )
    print("\nms per stage (median):")
    for name, r in results.items():
        for mode in ("raster", "full", "hybrid"):
            st = ", ".join(f"{k} {v:.1f}" for k, v in r[mode]["stages_ms"].items() if k != "frame")
            print(f"- {name} {mode}: frame {r[mode]['stages_ms']['frame']:.1f} ms ({st})")
    threads = next(iter(results.values()))["full"]["threads"] if results else 0
    print(f"\n{width}x{height}, {threads} threads, median of {args.repeats} after a warm-up")
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, {"size": [width, height], "scenes": results})


if __name__ == "__main__":
    main()
