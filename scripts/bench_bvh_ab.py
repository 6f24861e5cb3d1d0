"""The 4-wide BVH's queries, this checkout's traversal against another checkout's, in one process.

For each shared scene, rays from its 640x480 G-buffer points: hemisphere directions for
closest hits and segments to other surface points for any-hits (``bench_bvh.py``'s
rays), and the camera rays mirrored at each point (the renderer's reflection rays, closest
hits).  Every kind is queried through this checkout's ``wide_bvh`` traversal and through
the one of the checkout at ``--against DIR`` (e.g. a ``git worktree`` of an older commit:
its ``warp_hybrid`` package is loaded beside this one under another name), over the same
tree (this checkout's build, so the node layout must be the same: the answers are
compared ray for ray), launches alternating (12 each, the order swapped every round, the
first two of each dropped), one thread, thread CPU ns a ray, medians.  The machines
these run on drift by 10-20% between runs minutes apart; alternating launches in one
process leave about 10% between two launches of the same code.  Each scene runs in its
own subprocess.

    git worktree add /tmp/before HEAD~1
    .venv/bin/python scripts/bench_bvh_ab.py --against /tmp/before [--scenes staircase classroom] [--rays 60000]
"""

from __future__ import annotations

import importlib
import importlib.util
import statistics
import sys
import time
from pathlib import Path
from types import ModuleType

import numpy as np
import warp as wp
from bench_bvh import query_rays
from bench_common import run_per_scene

ROUNDS = 12
DROPPED = 2


def _against(checkout: str) -> ModuleType:
    """The ``wide_bvh`` module of the ``warp_hybrid`` package at ``checkout``, loaded as
    ``warp_hybrid_against`` (its own Warp modules, compiled apart from this checkout's)."""
    package = Path(checkout).resolve() / "warp_hybrid"
    if not (package / "scene" / "device" / "wide_bvh.py").is_file():
        raise SystemExit(f"--against {checkout}: no warp_hybrid/scene/device/wide_bvh.py there")
    spec = importlib.util.spec_from_file_location(
        "warp_hybrid_against", package / "__init__.py", submodule_search_locations=[str(package)]
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["warp_hybrid_against"] = module
    spec.loader.exec_module(module)
    return importlib.import_module("warp_hybrid_against.scene.device.wide_bvh")


def _query_kernel(traversal: ModuleType) -> wp.Kernel:
    """A kernel querying ``traversal``'s native closest-hit or any-hit function, a ray a thread."""

    @wp.kernel(module="unique")
    def queries(
        node_data: wp.array(dtype=wp.float32),
        leaves: wp.array(dtype=wp.int32),
        corners: wp.array(dtype=wp.float32),
        faces: wp.array(dtype=wp.int32),
        nodes: int,
        o: wp.array(dtype=wp.vec3),
        d: wp.array(dtype=wp.vec3),
        max_t: wp.array(dtype=float),
        closest: int,
        out: wp.array(dtype=wp.vec2),
    ):
        i = wp.tid()
        if closest != 0:
            r = traversal._closest(node_data, leaves, corners, faces, nodes, o[i], d[i], max_t[i])
            out[i] = wp.vec2(r[0], r[1])
        else:
            hit = traversal._any(node_data, leaves, corners, faces, nodes, o[i], d[i], max_t[i])
            out[i] = wp.vec2(wp.where(hit, 1.0, 0.0), 0.0)

    return queries


def measure_scene(path: str, width: int, height: int, repeats: int, against: str = "", rays: int = 60000) -> dict:
    """ns a ray of each query kind through both traversals (module docstring); ``repeats`` is unused."""
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.device import wide_bvh
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    kernels = {"this": _query_kernel(wide_bvh), "against": _query_kernel(_against(against))}
    scene = open_scene_source(path).scene_at(None)
    with Renderer(scene, RenderSettings(width=width, height=height, mode="raster")) as renderer:
        gbuffer = renderer.render(scene.cameras[0]).gbuffer
        origins, bounce, segment, length = query_rays(gbuffer, rays)
        pos = gbuffer.channel_numpy("position").reshape(-1, 3)
        nrm = gbuffer.channel_numpy("normal").reshape(-1, 3)
        hit = gbuffer.hit_mask().reshape(-1)
        step = max(1, int(hit.sum()) // rays)
        p, n = pos[hit][::step][:rays], nrm[hit][::step][:rays]
        view = p - np.asarray(scene.cameras[0].cam_to_world, dtype=np.float64)[:3, 3]
        view /= np.linalg.norm(view, axis=1, keepdims=True)
        mirror = view - 2.0 * (view * n).sum(1, keepdims=True) * n
        far = np.float32(1.0e30)
        kinds = {
            "closest_hemisphere": (origins, bounce, np.full(len(origins), far), 1),
            "closest_mirror": (p + np.float32(1.0e-3) * n, mirror, np.full(len(p), far), 1),
            "any_hit_segment": (origins, segment, length, 0),
        }
        tree = renderer.device_scene.wide_bvh.gpu
        out: dict = {"triangles": scene.triangle_count}
        for kind, (o, d, max_t, closest) in kinds.items():
            inputs = [
                wp.array(np.asarray(o, np.float32), dtype=wp.vec3),
                wp.array(np.asarray(d, np.float32), dtype=wp.vec3),
                wp.array(np.asarray(max_t, np.float32), dtype=float),
                closest,
            ]
            results = {name: wp.zeros(len(o), dtype=wp.vec2) for name in kernels}
            times: dict[str, list[float]] = {name: [] for name in kernels}
            for k in range(ROUNDS):
                for name in ("this", "against") if k % 2 == 0 else ("against", "this"):
                    start = time.thread_time()
                    args = [tree.node_data, tree.leaves, tree.corners, tree.faces, tree.nodes, *inputs, results[name]]
                    wp.launch(kernels[name], len(o), args)
                    times[name].append((time.thread_time() - start) * 1.0e9 / len(o))
            ns = {name: statistics.median(t[DROPPED:]) for name, t in times.items()}
            out[kind] = {
                "this_ns": ns["this"],
                "against_ns": ns["against"],
                "same_answers": bool(np.array_equal(results["this"].numpy(), results["against"].numpy())),
            }
    return out


def main() -> None:
    """Every scene in its own subprocess; print the table."""
    args, _width, _height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[
            ("--against", {"required": True, "help": "the other checkout's root (its warp_hybrid package)"}),
            ("--rays", {"type": int, "default": 60000, "help": "rays a kind (default 60000)"}),
        ],
    )
    print("| scene | query | against ns | this ns | this / against | same answers |")
    print("|---|---|---|---|---|---|")
    for name, r in results.items():
        for kind, q in r.items():
            if isinstance(q, dict):
                ratio = q["this_ns"] / q["against_ns"]
                print(
                    f"| {name} | {kind} | {q['against_ns']:.0f} | {q['this_ns']:.0f} | {ratio:.3f} "
                    f"| {'yes' if q['same_answers'] else 'NO'} |"
                )
    print(
        f"\none thread, {args.rays} rays a kind, medians of {ROUNDS - DROPPED} alternating launches, against {args.against}"
    )


if __name__ == "__main__":
    main()
