"""This project's frame stages beside Mitsuba 3 on the same views, as ratios from one run.

Mitsuba 3 (PyPI ``mitsuba``, the ``llvm_ad_rgb`` variant on the CPU, Dr.Jit on as many
threads as the renderer) is a benchmark-only dependency (``pip install -e .[bench]``):
nothing else imports it.  Per scene, on the same triangles, camera and lights, at the
same resolution (median of ``--repeats`` after a warm-up, everything evaluated and
synchronised inside the timing; each of this project's frames measured in turn with the
Mitsuba passes it is compared with, ``bench_common.interleaved_medians``, so a machine
whose speed drifts slows both sides of a ratio alike):

* **primary**: one camera ray per pixel centre through Mitsuba's BVH with the full
  surface interaction (position, shading frame, UVs, distance): against this project's
  raster-mode G-buffer stages (``raster + resolve + surface``) and the whole
  ``--mode raster`` frame, post included.  Every frame of this project is timed as the
  replay loop and the viewer render it (``render(..., host_copies=False)``): its 8-bit
  image read back, its linear colour and visibility left on the device, as Mitsuba's
  surface data are.
* **shadow**: one shadow ray per pixel per light from the primary hits (toward a
  light's centre, or along a distant light): against ``trace_shadow`` in ``--mode full``.
* **whitted**: primary, shadows, and one mirror bounce (and its shadows) where the hit's
  material reflects (metallic >= 0.5, or glass): against the whole ``--mode full`` frame.
* **same bounce**: the Whitted frame with this project's rule for where a reflection ray
  leaves (``path.py``: every smooth surface, roughness < ``SMOOTH_ROUGHNESS``, read per
  pixel from the G-buffer, so textured roughness counts; and every transmissive one, which
  also sends a ray on through it, as refraction does): against the ``--mode full`` frame
  with ``max_depth`` 1 (one bounce, as Mitsuba's), the equal-work comparison.  Both sides'
  ray counts are printed.  The default ``--mode full`` frame traces up to three bounces
  where Mitsuba's Whitted frame, by its own rule, may trace none (a scene without metal).

Rays are built on the host once (not timed).  Each scene runs in its own subprocess.

    .venv/bin/python scripts/bench_peer.py [--scenes staircase classroom] [--size 640x480] [--repeats 5] [--bvh wide|warp]
        [--json out/bench_peer.json]
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from bench_common import BVH_OPTION, interleaved_medians, run_per_scene, wide_bvh_setting

PRIMARY_STAGES = ("raster", "resolve", "surface")


def _camera_rays(camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(origins, unit directions), (H*W, 3) float32, through each pixel centre (row 0 at
    the top), the project's pinhole model (``Camera.tan_half_fov_*``)."""
    xs = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    ys = 1.0 - (np.arange(height) + 0.5) / height * 2.0
    px, py = np.meshgrid(xs * camera.tan_half_fov_x, ys * camera.tan_half_fov_y(width, height))
    local = np.stack([px, py, -np.ones_like(px)], axis=-1).reshape(-1, 3)
    m = np.asarray(camera.cam_to_world, dtype=np.float64)
    d = local @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(m[:3, 3], d.shape)
    return o.astype(np.float32), d.astype(np.float32)


def _mitsuba(
    scene,
    camera,
    width: int,
    height: int,
    threads: int,
    bounce_mask: np.ndarray,
    through_mask: np.ndarray,
) -> tuple[dict, dict[str, Callable[[], dict[str, float]]]]:
    """Mitsuba's view of the scene: what it sees (the share of pixels hit, the rays of the
    same bounce) and its timed passes by name (each returns its ms): primary, shadow,
    Whitted-style, and the Whitted frame whose bounce leaves from the pixels of
    ``bounce_mask`` ((H*W,) bool: reflection rays) and, on through the surface, from those
    of ``through_mask`` (refraction rays)."""
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(threads)
    points = np.ascontiguousarray(scene.points, dtype=np.float32)
    faces = np.ascontiguousarray(scene.indices, dtype=np.uint32)
    mesh = mi.Mesh("scene", vertex_count=len(points), face_count=len(faces), has_vertex_normals=False)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(points.ravel())
    params["faces"] = mi.UInt32(faces.ravel())
    params.update()
    mscene = mi.load_dict({"type": "scene", "mesh": mesh})
    origins, directions = _camera_rays(camera, width, height)
    rays = mi.Ray3f(
        mi.Point3f(*(mi.Float(origins[:, i]) for i in range(3))),
        mi.Vector3f(*(mi.Float(directions[:, i]) for i in range(3))),
    )
    reflective = np.array(
        [m.metallic >= 0.5 or (m.opacity < 1.0 and not m.thin_walled) for m in scene.materials], dtype=bool
    )
    tri_reflective = mi.Bool(reflective[scene.triangle_material] if len(reflective) else np.zeros(len(faces), bool))
    lights = [(int(light.kind), np.asarray(light.position), np.asarray(light.direction)) for light in scene.lights]

    def shadows(si) -> list:
        tests = []
        for kind, position, direction in lights:
            if kind == 0:  # distant: along the light's direction, toward it
                d = mi.Vector3f(*(float(-v) for v in direction / np.linalg.norm(direction)))
                ray = si.spawn_ray(d)
            else:
                ray = si.spawn_ray_to(mi.Point3f(*(float(v) for v in position)))
            tests.append(mscene.ray_test(ray, active=si.is_valid()))
        return tests

    def primary() -> dict[str, float]:
        start = time.perf_counter()
        si = mscene.ray_intersect(rays)
        dr.eval(si.p, si.sh_frame.n, si.uv, si.t, si.prim_index)
        dr.sync_thread()
        return {"primary": (time.perf_counter() - start) * 1000.0}

    si_fixed = mscene.ray_intersect(rays)
    dr.eval(si_fixed)
    hit_share = float(dr.count(si_fixed.is_valid())[0]) / (width * height)

    def shadow() -> dict[str, float]:
        start = time.perf_counter()
        dr.eval(*shadows(si_fixed))
        dr.sync_thread()
        return {"shadow": (time.perf_counter() - start) * 1000.0}

    def whitted() -> dict[str, float]:
        start = time.perf_counter()
        si = mscene.ray_intersect(rays)
        tests = shadows(si)
        mirror = si.is_valid() & dr.gather(mi.Bool, tri_reflective, si.prim_index, si.is_valid())
        bounce = mscene.ray_intersect(si.spawn_ray(si.to_world(mi.reflect(si.wi))), active=mirror)
        tests += shadows(bounce)
        dr.eval(si.p, si.sh_frame.n, si.uv, bounce.p, bounce.sh_frame.n, *tests)
        dr.sync_thread()
        return {"whitted": (time.perf_counter() - start) * 1000.0}

    bounce_at = mi.Bool(bounce_mask)
    through_at = mi.Bool(through_mask)

    def same_bounce() -> dict[str, float]:
        start = time.perf_counter()
        si = mscene.ray_intersect(rays)
        tests = shadows(si)
        bounce = mscene.ray_intersect(si.spawn_ray(si.to_world(mi.reflect(si.wi))), active=si.is_valid() & bounce_at)
        through = mscene.ray_intersect(si.spawn_ray(-si.to_world(si.wi)), active=si.is_valid() & through_at)
        tests += shadows(bounce) + shadows(through)
        dr.eval(si.p, si.sh_frame.n, si.uv, bounce.p, bounce.sh_frame.n, through.p, through.sh_frame.n, *tests)
        dr.sync_thread()
        return {"same_bounce": (time.perf_counter() - start) * 1000.0}

    info = {
        "hit_share": hit_share,
        "rays": {"reflection": int(bounce_mask.sum()), "refraction": int(through_mask.sum())},
    }
    return info, {"primary": primary, "shadow": shadow, "whitted": whitted, "same_bounce": same_bounce}


def measure_scene(path: str, width: int, height: int, repeats: int, bvh: str = "wide") -> dict:
    """This project's raster and full frames and Mitsuba's passes on one scene, each of
    ours in turn with the Mitsuba passes it is compared with (``interleaved_medians``)."""
    from warp_hybrid.core.constants import SMOOTH_ROUGHNESS
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    scene = open_scene_source(path).scene_at(None)
    camera = scene.cameras[0]
    ours: dict[str, dict[str, float]] = {}
    rays: dict[str, dict[str, int]] = {}
    peer: dict = {}
    passes: dict[str, Callable[[], dict[str, float]]] = {}
    threads = 0
    transmissive = np.array([m.is_glass for m in scene.materials] + [False], dtype=bool)  # FLAG_TRANSMISSIVE
    # each of our frames with the Mitsuba passes it is compared with
    compared = {"raster": ("primary",), "full": ("shadow", "whitted"), "full_depth1": ("same_bounce",)}
    for key, mode, depth in (("raster", "raster", 3), ("full", "full", 3), ("full_depth1", "full", 1)):
        settings = RenderSettings(
            width=width, height=height, mode=mode, max_depth=depth, wide_bvh=wide_bvh_setting(bvh)
        )
        with Renderer(scene, settings) as r:
            threads = r.launcher.threads

            def frame() -> dict[str, float]:
                f = r.render(camera, host_copies=False)
                rays[key] = f.stats.get("rays", {})
                return {**f.stats["stages_ms"], "frame": f.stats["frame_ms"]}

            if key == "raster":  # the G-buffer is the same in every mode: where Mitsuba's bounce leaves
                frame()
                gb = r.buffers.gbuffer
                hit = gb.hit_mask().ravel()
                roughness = gb.channel_numpy("optics")[..., 3].ravel()
                through = hit & transmissive[gb.material_id.numpy().ravel()]
                bounce = hit & ((roughness < float(SMOOTH_ROUGHNESS)) | through)
                peer, passes = _mitsuba(scene, camera, width, height, threads, bounce, through)
            names = compared[key]
            ours[key], *theirs = interleaved_medians([frame, *(passes[n] for n in names)], repeats)
            for times in theirs:
                peer.update(times)
    hit_share = float(hit.mean())
    primary = sum(ours["raster"].get(s, 0.0) for s in PRIMARY_STAGES)
    return {
        "triangles": scene.triangle_count,
        "lights": len(scene.lights),
        "threads": threads,
        "ours": ours,
        "mitsuba": peer,
        "ratios": {
            "primary": primary / peer["primary"],
            "raster_frame": ours["raster"]["frame"] / peer["primary"],
            "shadow": ours["full"].get("trace_shadow", 0.0) / peer["shadow"] if peer["shadow"] else 0.0,
            "full_frame": ours["full"]["frame"] / peer["whitted"],
            "same_bounce": ours["full_depth1"]["frame"] / peer["same_bounce"],
        },
        "rays_depth1": rays["full_depth1"],
        "primary_ms": primary,
        "hit_share": hit_share,
    }


def main() -> None:
    """Run the benchmark and print the table."""
    args, width, height, results = run_per_scene(__doc__.splitlines()[0], __file__, measure_scene, options=[BVH_OPTION])
    print(
        "| scene | triangles | lights | G-buffer ms / Mitsuba primary ms | raster frame / primary | "
        "trace_shadow ms / Mitsuba shadow ms | full frame ms / Mitsuba Whitted ms | "
        "full frame, max depth 1 / Mitsuba same bounce | reflection + refraction rays, ours / Mitsuba's |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, r in results.items():
        o, m, q = r["ours"], r["mitsuba"], r["ratios"]
        print(
            f"| {name} | {r['triangles']} | {r['lights']} | {r['primary_ms']:.1f} / {m['primary']:.1f} = "
            f"{q['primary']:.2f}x | {o['raster']['frame']:.1f} ms = {q['raster_frame']:.2f}x | "
            f"{o['full'].get('trace_shadow', 0.0):.1f} / {m['shadow']:.1f} = {q['shadow']:.2f}x | "
            f"{o['full']['frame']:.1f} / {m['whitted']:.1f} = {q['full_frame']:.2f}x | "
            f"{o['full_depth1']['frame']:.1f} / {m['same_bounce']:.1f} = {q['same_bounce']:.2f}x | "
            f"{r['rays_depth1'].get('reflection', 0) + r['rays_depth1'].get('refraction', 0)} / "
            f"{m['rays']['reflection'] + m['rays']['refraction']} |"
        )
    threads = next(iter(results.values()))["threads"] if results else 0
    print(f"\n{width}x{height}, {threads} threads on both, median of {args.repeats} after a warm-up, each side in turn")
    shares = ", ".join(f"{n} {r['hit_share']:.3f} / {r['mitsuba']['hit_share']:.3f}" for n, r in results.items())
    print(f"share of pixels that see a surface, ours / Mitsuba's (the same view): {shares}")
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, {"size": [width, height], "scenes": results})


if __name__ == "__main__":
    main()
