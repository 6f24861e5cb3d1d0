"""What each band of the coverage pass costs, timed alone on one thread.

    .venv/bin/python scripts/coverage_bands.py SCENE [--size 640x480] [--bands 16] [--repeats 5] [--round-robin]

Rasterizes one frame of SCENE's first camera, then launches the coverage kernel over each
of ``--bands`` equal bands of clusters by itself (``parallel.band``; with ``--round-robin``
band k takes every ``bands``-th cluster from k instead) and prints the pass's CPU time and
each band's share of it as a multiple of the mean (1.00 = an equal share).  It shows how
unevenly a scene's clusters cost, which ``parallel.CostBands`` evens out between threads.
"""

from __future__ import annotations

import argparse
import time

import bench_common  # noqa: F401  (puts the checkout on sys.path)


def main() -> None:
    """Time the bands and print their shares."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--bands", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--round-robin", action="store_true", help="band k takes clusters k, k + bands, ...")
    args = ap.parse_args()
    import warp as wp

    from warp_hybrid.core.camera import make_camera_gpu
    from warp_hybrid.core.gbuffer import GBuffer
    from warp_hybrid.parallel import Launcher, band
    from warp_hybrid.primary import Rasterizer, kernels
    from warp_hybrid.primary.coverage import MODE_DEPTH, RasterTarget
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.device import DeviceScene
    from warp_hybrid.scene.open import open_scene_source
    from warp_hybrid.timing import StageTimer

    init_warp()
    width, height = (int(v) for v in args.size.split("x"))
    scene = open_scene_source(args.scene).scene_at(None)
    with Launcher("cpu", threads=1) as launcher:
        device_scene = DeviceScene(scene, "cpu")
        camera = make_camera_gpu(scene.cameras[0], width, height)
        rasterizer = Rasterizer(launcher)
        rasterizer.find_hits(device_scene, camera, GBuffer(width, height, "cpu"), StageTimer())
        points, bounds = rasterizer.projected_points, rasterizer.cluster_boxes
        clusters = bounds.shape[0]
        target = RasterTarget()
        target.keys = rasterizer.key_slices
        target.slot, target.mode, target.row_begin, target.row_end = 0, MODE_DEPTH, 0, height
        costs = [0.0] * args.bands
        for _ in range(args.repeats):
            for k in range(args.bands):
                if args.round_robin:
                    first, size, step = k, -(-(clusters - k) // args.bands), args.bands
                else:
                    (first, size), step = band(k, args.bands, clusters), 1
                inputs = [device_scene.gpu, camera, points, target, bounds, scene.triangle_count, first, step]
                start = time.thread_time()
                wp.launch(kernels.coverage_kernel, dim=size, inputs=inputs, device="cpu")
                costs[k] += (time.thread_time() - start) / args.repeats
    total = sum(costs)
    print(f"{args.scene}: {clusters} clusters, coverage {total * 1e3:.2f} CPU ms on one thread")
    print("band cost / mean: " + " ".join(f"{c / total * args.bands:.2f}" for c in costs))


if __name__ == "__main__":
    main()
