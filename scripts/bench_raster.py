"""Benchmark the raster G-buffer against ray-cast primaries on the shared scenes.

For each scene at 640x480 (median of 5 after a warm-up): ms for load, upload, BVH
build, raster, resolve, the attribute pass both paths share (surface), lighting, and
for casting the primaries instead of raster + resolve (raster and resolve timed as the
hit record's passes alone, ``Rasterizer.find_hits``, as the casters are: a frame's
surface pass resolves the raster hit record itself, its time in ``surface``;
``raycast``: through the scene's
4-wide BVH copy on the CPU, Warp's query on CUDA; ``raycast warp``: through
``wp.mesh_query_ray`` on the CPU too, alternating with the other in one process);
the speed ratio of primary visibility; the share of pixels where the two
G-buffers agree (depth within 1e-4 relative, same hit/miss); peak RSS; and, once per
run, the cold start (every kernel compiled from an empty cache, first frame).

Each scene runs in its own subprocess so its peak RSS is its own.

    .venv/bin/python scripts/bench_raster.py [--scenes staircase classroom] [--size 640x480]
        [--repeats 5] [--device cpu|cuda:0] [--json out/bench_raster.json]
    WARP_HYBRID_THREADS=1 .venv/bin/python scripts/bench_raster.py ...   # one host thread
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time

from bench_common import ROOT, manifest_scenes, median_ms, peak_rss_mb, run_per_scene


def measure_scene(path: str, width: int, height: int, repeats: int, device: str = "cpu") -> dict:
    """Measure one scene in this process on ``device``; returns a JSON-ready dict."""
    import numpy as np

    from warp_hybrid.core.camera import make_camera_gpu
    from warp_hybrid.core.gbuffer import GBuffer
    from warp_hybrid.parallel import Launcher
    from warp_hybrid.primary import Rasterizer, RayCaster
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source
    from warp_hybrid.timing import StageTimer

    init_warp()
    t0 = time.perf_counter()
    scene = open_scene_source(path).scene_at(None)
    load_ms = (time.perf_counter() - t0) * 1000.0
    renderer = Renderer(scene, RenderSettings(width=width, height=height, device=device))
    camera = scene.cameras[0]

    def frame() -> dict[str, float]:
        return renderer.render(camera).stats["stages_ms"]

    stages = median_ms(frame, repeats)
    raster_gb = renderer.buffers.gbuffer.aovs()
    raster_ids = renderer.buffers.gbuffer.triangle_id.numpy().copy()

    cam = make_camera_gpu(camera, width, height)
    ray_gb = GBuffer(width, height, renderer.device)
    launcher = Launcher(renderer.device, renderer.launcher.threads)
    casters = {"raycast": RayCaster(launcher)}
    if renderer.device.is_cpu:
        casters["raycast_warp"] = RayCaster(launcher, wide_bvh=False)

    rasterizer, hits_gb = Rasterizer(launcher), GBuffer(width, height, renderer.device)

    def cast() -> dict[str, float]:
        timer = StageTimer()
        rasterizer.find_hits(renderer.device_scene, cam, hits_gb, timer)  # the raster hit record's passes alone
        out = {"raster": timer.stages_ms["raster"], "resolve": timer.stages_ms["resolve"]}
        for name, caster in reversed(casters.items()):  # the default last: its G-buffer is compared
            timer = StageTimer()
            caster.render(renderer.device_scene, cam, ray_gb, timer)
            out[name] = timer.stages_ms["raycast"]
        return out

    stages.update(median_ms(cast, repeats))
    stages.setdefault("raycast_warp", float("nan"))
    ray = ray_gb.aovs()
    hit_r, hit_c = np.isfinite(raster_gb["depth"]), np.isfinite(ray["depth"])
    both = hit_r & hit_c
    rel = np.zeros_like(raster_gb["depth"])
    rel[both] = np.abs(raster_gb["depth"][both] - ray["depth"][both]) / np.maximum(ray["depth"][both], 1e-30)
    agree = (hit_r == hit_c) & (~both | (rel <= 1e-4))
    ids_agree = raster_ids == ray_gb.triangle_id.numpy()
    renderer.close()
    return {
        "triangles": scene.triangle_count,
        "load_ms": load_ms,
        **{f"{k}_ms": v for k, v in renderer.setup_ms.items()},
        **{f"{k}_ms": v for k, v in stages.items()},
        "depth_agreement": float(agree.mean()),
        "triangle_id_agreement": float(ids_agree.mean()),
        "peak_rss_mb": peak_rss_mb(),
        "threads": renderer.launcher.threads,
    }


def cold_start(path: str, width: int, height: int) -> float:
    """Seconds from an empty kernel cache to the first finished frame (subprocess)."""
    with tempfile.TemporaryDirectory() as cache:
        code = (
            "import time; t=time.perf_counter();"
            "from warp_hybrid.runtime import init_warp; init_warp();"
            "from warp_hybrid.scene.open import open_scene_source;"
            "from warp_hybrid.renderer import Renderer, RenderSettings;"
            f"s=open_scene_source({path!r}).scene_at(None);"
            f"r=Renderer(s, RenderSettings(width={width}, height={height})); r.render(s.cameras[0]);"
            "print(time.perf_counter()-t)"
        )
        env = {**__import__("os").environ, "WARP_HYBRID_KERNEL_CACHE": cache}
        out = subprocess.run(
            [sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, check=True
        )
        return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    """Run the benchmark and print a markdown table."""
    args, width, height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[("--device", {"default": "cpu", "help": "Warp device (cpu or cuda:0)"})],
    )
    biggest = max(manifest_scenes(args.scenes), key=lambda e: e["triangles"])
    # the cold start compiles the CPU kernels: measured on CPU runs only
    cold = cold_start(biggest["path"], width, height) if args.device == "cpu" else None
    cols = [
        "triangles",
        "load_ms",
        "bvh_build_ms",
        "raster_ms",
        "resolve_ms",
        "surface_ms",
        "lighting_ms",
        "raycast_ms",
        "raycast_warp_ms",
    ]
    print(
        f"| scene | {' | '.join(c.replace('_ms', ' ms') for c in cols)} | raster+resolve vs raycast | depth agree | ids agree | peak RSS MB |"
    )
    print("|" + "---|" * (len(cols) + 5))
    for name, r in results.items():
        ratio = r["raycast_ms"] / (r["raster_ms"] + r["resolve_ms"])
        vals = " | ".join(f"{r[c]:.0f}" if c == "triangles" else f"{r[c]:.1f}" for c in cols)
        print(
            f"| {name} | {vals} | {ratio:.1f}x | {100 * r['depth_agreement']:.3f}% | {100 * r['triangle_id_agreement']:.3f}% | {r['peak_rss_mb']:.0f} |"
        )
    threads = next(iter(results.values()))["threads"] if results else 0
    cold_text = f"{cold:.1f} s" if cold is not None else "not measured off the CPU"
    print(
        f"\n{width}x{height}, {args.device}, {threads} threads, median of {args.repeats} after a warm-up; "
        f"cold start ({biggest['name']}, empty kernel cache to first frame): {cold_text}"
    )
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, {"size": [width, height], "cold_start_s": cold, "scenes": results})


if __name__ == "__main__":
    main()
