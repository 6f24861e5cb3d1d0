"""The CPU ray queries alone: ns per ray of a closest hit and of an any-hit on one thread.

For each shared scene, rays from its 640x480 G-buffer (``--size``): ``--rays`` surface
points (seeded), each offset along its normal, cast in a random direction of its
hemisphere for the closest hit (as a diffuse or glossy bounce goes) and toward another
surface point for the any-hit (a segment, as a shadow ray).  ``--bvh wide`` (default)
queries the scene's 4-wide BVH (``scene/device/wide_bvh.py``, its build timed once more
after the first), ``--bvh warp`` Warp's own queries on the scene's ``wp.Mesh``.  One launch
per query type per repeat, on one thread (a plain ``wp.launch`` on the CPU); medians.
Prints the tree's nodes and build time and the two query times, and writes each scene's
answers (face and distance of the closest hits, the any-hit flags) to ``--answers DIR``
when given, to compare two trees or two checkouts ray for ray.  With the 4-wide BVH it
also times the primary shadow rays toward the scene's first light (every hit pixel in
row order, as the shadow pass lists them) one at a time and as packets of ``PACKET``
neighbours (``wide_any_hit_packet``, the shadow pass's query), and the mirror rays of
every hit pixel (the camera ray reflected about the shading normal, in row order: the
path kernel's first rays where every surface were a mirror) one at a time and as packets
(``wide_closest_packet``), and checks each pair answers alike.

    .venv/bin/python scripts/bench_bvh.py [--scenes staircase classroom] [--rays 100000] [--repeats 5]
        [--bvh wide|warp] [--answers out/bvh_answers] [--json out/bench_bvh.json]
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np
import warp as wp
from bench_common import run_per_scene

from warp_hybrid.scene.device.wide_bvh import (
    PACKET,
    WideBVH,
    WideBVHGPU,
    closest_hits,
    packet_any_hits,
    packet_closest_hits,
    wide_any_hit,
    wide_closest,
)


@wp.kernel
def wide_queries(
    tree: WideBVHGPU,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    closest: int,
    out: wp.array(dtype=wp.vec2),
):
    """One query a ray on the 4-wide BVH: (face or -1, distance) of the closest hit, or
    (1 or 0, 0) for the any-hit."""
    i = wp.tid()
    if closest != 0:
        h = wide_closest(tree, o[i], d[i], max_t[i])
        out[i] = wp.vec2(wp.where(h.result, float(h.face), -1.0), h.t)
    else:
        out[i] = wp.vec2(wp.where(wide_any_hit(tree, o[i], d[i], max_t[i]), 1.0, 0.0), 0.0)


@wp.kernel
def warp_queries(
    mesh: wp.uint64,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    closest: int,
    out: wp.array(dtype=wp.vec2),
):
    """``wide_queries`` with Warp's own queries on the mesh."""
    i = wp.tid()
    if closest != 0:
        q = wp.mesh_query_ray(mesh, o[i], d[i], max_t[i])
        out[i] = wp.vec2(wp.where(q.result, float(q.face), -1.0), q.t)
    else:
        out[i] = wp.vec2(wp.where(wp.mesh_query_ray_anyhit(mesh, o[i], d[i], max_t[i]), 1.0, 0.0), 0.0)


def light_rays(gbuffer: object, light: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origins, directions, lengths) of every hit pixel's shadow ray toward ``light``'s
    centre (along a distant light), in row order, each leaving on the light's side."""
    from warp_hybrid.scene.model import LightKind

    pos = gbuffer.channel_numpy("position").reshape(-1, 3).astype(np.float64)
    nrm = gbuffer.channel_numpy("geometric_normal").reshape(-1, 3).astype(np.float64)
    hit = gbuffer.hit_mask().reshape(-1)
    pos, nrm = pos[hit], nrm[hit]
    if light.kind == LightKind.DISTANT:
        d = np.broadcast_to(-np.asarray(light.direction, np.float64), pos.shape)
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        length = np.full(len(pos), 1.0e30)
    else:
        to = np.asarray(light.position, np.float64) - pos
        length = np.linalg.norm(to, axis=1)
        d = to / np.maximum(length, 1.0e-30)[:, None]
        length = 0.999 * length
    side = np.where((d * nrm).sum(1, keepdims=True) < 0.0, -nrm, nrm)
    f32 = np.float32
    return (pos + 1.0e-3 * side).astype(f32), d.astype(f32), length.astype(f32)


def mirror_rays(gbuffer: object, eye: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origins, directions, lengths) of every hit pixel's mirror ray, in row order: the
    ray from ``eye`` reflected about the shading normal, leaving on its side of the surface."""
    pos = gbuffer.channel_numpy("position").reshape(-1, 3).astype(np.float64)
    nrm = gbuffer.channel_numpy("normal").reshape(-1, 3).astype(np.float64)
    geo = gbuffer.channel_numpy("geometric_normal").reshape(-1, 3).astype(np.float64)
    hit = gbuffer.hit_mask().reshape(-1)
    pos, nrm, geo = pos[hit], nrm[hit], geo[hit]
    v = pos - eye
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    d = v - 2.0 * (v * nrm).sum(1, keepdims=True) * nrm
    side = np.where((d * geo).sum(1, keepdims=True) < 0.0, -geo, geo)
    f32 = np.float32
    return (pos + 1.0e-3 * side).astype(f32), d.astype(f32), np.full(len(pos), 1.0e30, f32)


def query_rays(gbuffer: object, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(origins, hemisphere directions, segment directions, segment lengths) from the
    G-buffer's hit points."""
    pos = gbuffer.channel_numpy("position").reshape(-1, 3)
    nrm = gbuffer.channel_numpy("normal").reshape(-1, 3)
    hit = gbuffer.hit_mask().reshape(-1)
    pos, nrm = pos[hit], nrm[hit]
    rng = np.random.default_rng(1)
    pick = rng.choice(len(pos), size=min(count, len(pos)), replace=False)
    origins = pos[pick] + 1.0e-3 * nrm[pick]
    bounce = rng.normal(size=origins.shape)
    bounce /= np.linalg.norm(bounce, axis=1, keepdims=True)
    bounce = np.where((bounce * nrm[pick]).sum(1, keepdims=True) < 0.0, -bounce, bounce)
    other = rng.choice(len(pos), size=len(origins))
    segment = pos[other] + 1.0e-3 * nrm[other] - origins
    length = np.linalg.norm(segment, axis=1)
    segment /= np.maximum(length, 1.0e-30)[:, None]
    f32 = np.float32
    return origins.astype(f32), bounce.astype(f32), segment.astype(f32), (0.999 * length).astype(f32)


def _any_hit_pair(tree: WideBVHGPU, o: wp.array, d: wp.array, max_t: wp.array) -> tuple[dict, tuple]:
    """The any-hit rays one at a time and as packets: the two launches and how to read
    each one's answers (blocked or not, one column)."""
    n = len(o)
    lit = wp.zeros(n, dtype=wp.vec2)
    blocked = wp.zeros(n, dtype=wp.int32)
    launches = {
        "one": lambda: wp.launch(wide_queries, n, [tree, o, d, max_t, 0, lit]),
        "packet": lambda: wp.launch(packet_any_hits, -(-n // PACKET), [tree, o, d, max_t, blocked]),
    }
    return launches, (lambda: lit.numpy()[:, :1], lambda: blocked.numpy().astype(np.float32)[:, None])


def _closest_pair(tree: WideBVHGPU, o: wp.array, d: wp.array, max_t: wp.array) -> tuple[dict, tuple]:
    """The closest-hit rays one at a time and as packets: the two launches and how to read
    each one's answers (face, t, u, v)."""
    n = len(o)
    one, packet = wp.zeros(n, dtype=wp.vec4), wp.zeros(n, dtype=wp.vec4)
    normals = wp.zeros(n, dtype=wp.vec3)
    launches = {
        "one": lambda: wp.launch(closest_hits, n, [tree, o, d, max_t, one, normals]),
        "packet": lambda: wp.launch(packet_closest_hits, -(-n // PACKET), [tree, o, d, max_t, packet, normals]),
    }
    return launches, (lambda: one.numpy(), lambda: packet.numpy())


def measure_scene(
    path: str, width: int, height: int, repeats: int, rays: int = 100000, bvh: str = "wide", answers: str = ""
) -> dict:
    """Query times of one scene's rays (module docstring)."""
    from warp_hybrid.core.camera import make_camera_gpu
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(path).scene_at(None)
    with Renderer(scene, RenderSettings(width=width, height=height, mode="raster")) as renderer:
        gbuffer = renderer.render(scene.cameras[0]).gbuffer
        origins, bounce, segment, length = query_rays(gbuffer, rays)
        device_scene = renderer.device_scene
        mesh = device_scene.mesh
        out: dict = {"triangles": scene.triangle_count, "rays": len(origins)}
        if bvh == "wide":
            device_scene.wide_bvh  # noqa: B018  (the first build loads the module)
            start = time.perf_counter()
            tree = WideBVH(mesh, scene.triangle_count)
            out["build_ms"] = (time.perf_counter() - start) * 1000.0
            out["nodes"] = tree.node_count
            kernel, first = wide_queries, tree.gpu
        else:
            kernel, first = warp_queries, wp.uint64(mesh.id)
        o = wp.array(origins, dtype=wp.vec3)
        far = wp.array(np.full(len(origins), 1.0e30, np.float32), dtype=float)
        kinds = {
            "closest": (wp.array(bounce, dtype=wp.vec3), far, 1),
            "any_hit": (wp.array(segment, dtype=wp.vec3), wp.array(length, dtype=float), 0),
        }
        result = wp.zeros(len(origins), dtype=wp.vec2)
        found = {}
        for kind, (d, max_t, closest) in kinds.items():
            times = []
            for _ in range(repeats + 1):  # the first launch is the warm-up
                start = time.perf_counter()
                wp.launch(kernel, len(origins), [first, o, d, max_t, closest, result])
                wp.synchronize()
                times.append((time.perf_counter() - start) * 1.0e9 / len(origins))
            out[f"{kind}_ns"] = statistics.median(times[1:])
            found[kind] = result.numpy().copy()
        if bvh == "wide":
            eye = np.asarray(make_camera_gpu(scene.cameras[0], width, height).origin, np.float64)
            pairs = {"mirror": (mirror_rays(gbuffer, eye), _closest_pair)}
            if scene.lights:
                pairs["light"] = (light_rays(gbuffer, scene.lights[0]), _any_hit_pair)
            for name, (rays, pair) in pairs.items():
                lo, ld, lt = (wp.array(a, dtype=t) for a, t in zip(rays, (wp.vec3, wp.vec3, float)))
                launches, answers_of = pair(first, lo, ld, lt)
                times = {k: [] for k in launches}
                for _ in range(repeats + 1):
                    for kind, launch in launches.items():  # alternating
                        start = time.perf_counter()
                        launch()
                        wp.synchronize()
                        times[kind].append((time.perf_counter() - start) * 1.0e9 / len(lo))
                for kind in launches:
                    out[f"{name}_{kind}_ns"] = statistics.median(times[kind][1:])
                one, packet = (answer() for answer in answers_of)
                out[f"{name}_rays"] = len(lo)
                out[f"{name}_differ"] = int((one != packet).any(axis=1).sum())
    if answers:
        folder = Path(answers)
        folder.mkdir(parents=True, exist_ok=True)
        table = np.concatenate([found["closest"], found["any_hit"][:, :1]], axis=1)
        np.save(folder / f"{Path(path).stem}_{bvh}.npy", table)
    return out


def main() -> None:
    """Every scene in its own subprocess; print the table."""
    args, _width, _height, results = run_per_scene(
        __doc__.splitlines()[0],
        __file__,
        measure_scene,
        options=[
            ("--rays", {"type": int, "default": 100000, "help": "rays per query type (default 100000)"}),
            ("--bvh", {"choices": ("wide", "warp"), "default": "wide", "help": "the 4-wide BVH or Warp's queries"}),
            ("--answers", {"default": "", "help": "write each scene's answers (.npy) into this folder"}),
        ],
    )
    print(
        "| scene | triangles | rays | nodes | build ms | closest hit ns | any-hit ns "
        "| light rays, one / packet ns (answers differing) | mirror rays, one / packet ns (answers differing) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, r in results.items():
        nodes = r.get("nodes", "-")
        build = f"{r['build_ms']:.0f}" if "build_ms" in r else "-"
        pairs = []
        for kind in ("light", "mirror"):
            if f"{kind}_one_ns" in r:
                one, packet = r[f"{kind}_one_ns"], r[f"{kind}_packet_ns"]
                pairs.append(f"{one:.0f} / {packet:.0f} = {one / packet:.2f}x ({r[f'{kind}_differ']})")
            else:
                pairs.append("-")
        print(
            f"| {name} | {r['triangles']} | {r['rays']} | {nodes} | {build} | {r['closest_ns']:.0f} | "
            f"{r['any_hit_ns']:.0f} | {pairs[0]} | {pairs[1]} |"
        )
    print(f"\n--bvh {args.bvh}, one thread, medians of {args.repeats}")
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, results)


if __name__ == "__main__":
    main()
