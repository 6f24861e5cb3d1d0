"""Regenerate the project's own scenes (CC0) deterministically.

    python scripts/make_scenes.py [OUT_DIR]        # default: scenes/ in the repository

Writes cornell_glass.usda, metal_env.usda, hard_cases.usda, textured_animated.usda and
textures/{sky.hdr, orientation.png}.  No randomness and fixed tessellations, so running
it twice gives byte-identical files (tests/test_shipped_scenes.py checks the shipped
copies against a fresh run).  What each scene is for: scenes/README.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # runnable as a plain script from a checkout
    sys.path.insert(0, str(ROOT))

from pxr import Gf, Usd, UsdGeom  # noqa: E402

from warp_hybrid.output import atomic_write_bytes  # noqa: E402
from warp_hybrid.scene.authoring import writer as uw  # noqa: E402
from warp_hybrid.scene.authoring.builders import uv_sphere  # noqa: E402

SKY_SIZE = (256, 128)
SUN_LON_DEG, SUN_LAT_DEG, SUN_RADIUS_DEG = -40.0, 35.0, 4.0
GLASS = {"transmission": 1.0, "thinWalled": False}
HARD_SUN = (-0.5, -0.8, -0.35)


# ----------------------------------------------------------------------------- geometry


def _rot_y(deg: float) -> np.ndarray:
    """3x3 rotation about +Y by ``deg`` degrees (column vectors)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def quad(center, edge_u, edge_v) -> tuple[np.ndarray, ...]:
    """A parallelogram centred at ``center`` spanning ``edge_u`` x ``edge_v`` (full
    lengths), facing ``edge_u x edge_v``; uv (0, 0) at ``center - (edge_u + edge_v) / 2``."""
    c, u, v = (np.asarray(a, dtype=np.float64) for a in (center, edge_u, edge_v))
    corner = c - (u + v) / 2.0
    pts = np.array([corner, corner + u, corner + u + v, corner + v])
    n = np.cross(u, v)
    nrm = np.tile(n / np.linalg.norm(n), (4, 1))
    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return pts, np.array([[0, 1, 2], [0, 2, 3]]), nrm, uvs


def box(center, size, rot_y_deg: float = 0.0) -> tuple[np.ndarray, ...]:
    """A flat-shaded box (24 split vertices, 12 triangles, uv 0..1 per face) of ``size``
    rotated about +Y by ``rot_y_deg`` degrees, then moved to ``center``."""
    half = np.asarray(size, dtype=np.float64) / 2.0
    pts, idx, nrm, uvs = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n, u = np.zeros(3), np.zeros(3)
            n[axis], u[(axis + 1) % 3] = sign, 1.0
            v = np.cross(n, u)
            p, i, fn, t = quad(n * half, u * 2.0 * half, v * 2.0 * np.abs(v @ half))
            idx.append(i + 4 * len(pts))
            pts.append(p)
            nrm.append(fn)
            uvs.append(t)
    rot = _rot_y(rot_y_deg)
    p = np.concatenate(pts) @ rot.T + np.asarray(center, dtype=np.float64)
    return p, np.concatenate(idx), np.concatenate(nrm) @ rot.T, np.concatenate(uvs)


def prism(a, b, c, y0: float, y1: float) -> tuple[np.ndarray, ...]:
    """A flat-shaded vertical prism over the triangle (a, b, c) of (x, z) points, from
    height ``y0`` to ``y1``: 2 caps + 3 sides = 8 triangles, wound to face outwards."""
    lo = [np.array([p[0], y0, p[1]], dtype=np.float64) for p in (a, b, c)]
    hi = [p + (0.0, y1 - y0, 0.0) for p in lo]
    centre = np.mean(lo + hi, axis=0)
    pts, idx, nrm, uvs = [], [], [], []
    for face in [lo, hi] + [[lo[i], lo[(i + 1) % 3], hi[(i + 1) % 3], hi[i]] for i in range(3)]:
        poly = np.array(face)
        n = np.cross(poly[1] - poly[0], poly[2] - poly[0])
        if n @ (poly.mean(axis=0) - centre) < 0.0:
            poly, n = poly[::-1], -n
        first = sum(len(q) for q in pts)
        idx += [[first, first + k, first + k + 1] for k in range(1, len(poly) - 1)]
        pts.append(poly)
        nrm.append(np.tile(n / np.linalg.norm(n), (len(poly), 1)))
        uvs.append(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])[: len(poly)])
    return np.concatenate(pts), np.array(idx), np.concatenate(nrm), np.concatenate(uvs)


def sphere(center, radius: float, rings: int, segments: int) -> tuple[np.ndarray, ...]:
    """A smooth UV sphere (the builders' layout: uv = longitude, latitude)."""
    m = uv_sphere(tuple(center), radius, rings, segments)
    return m.points, m.indices, m.normals, m.uvs


def torus_knot(center, scale: float, tube: float, p: int = 2, q: int = 3, segments: int = 192, sides: int = 12):
    """A (p, q) torus knot tube with analytic smooth normals, lying in the XY plane."""
    t = np.linspace(0.0, 2.0 * np.pi, segments + 1)

    def curve(tt: np.ndarray) -> np.ndarray:
        r = 2.0 + np.cos(q * tt)
        return scale * np.stack([r * np.cos(p * tt), r * np.sin(p * tt), -np.sin(q * tt)], axis=-1)

    c0, c1 = curve(t), curve(t + 1e-3)
    tangent = c1 - c0
    normal = c1 + c0
    binormal = np.cross(tangent, normal)
    normal = np.cross(binormal, tangent)
    binormal /= np.linalg.norm(binormal, axis=1, keepdims=True)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    a = np.linspace(0.0, 2.0 * np.pi, sides + 1)
    ring = np.cos(a)[None, :, None] * normal[:, None, :] + np.sin(a)[None, :, None] * binormal[:, None, :]
    pts = (c0[:, None, :] + tube * ring).reshape(-1, 3) + np.asarray(center, dtype=np.float64)
    nrm = ring.reshape(-1, 3)
    s, k = np.meshgrid(np.arange(segments), np.arange(sides), indexing="ij")
    w = sides + 1
    v00, v01, v10, v11 = s * w + k, s * w + k + 1, (s + 1) * w + k, (s + 1) * w + k + 1
    idx = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3), np.stack([v00, v11, v01], -1).reshape(-1, 3)])
    uv = np.stack(np.meshgrid(t / (2.0 * np.pi), a / (2.0 * np.pi), indexing="ij"), axis=-1).reshape(-1, 2)
    # wind counter-clockwise seen from outside (normals point away from the tube axis)
    tri = pts[idx]
    if np.einsum("ij,ij->", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), nrm[idx[:, 0]]) < 0.0:
        idx = idx[:, [0, 2, 1]]
    return pts, idx, nrm, uv


def add_mesh(stage: Usd.Stage, path: str, mesh: tuple[np.ndarray, ...], material, **kwargs) -> UsdGeom.Mesh:
    """Author ``mesh`` = (points, triangles, normals, uvs) at ``path`` bound to ``material``."""
    pts, idx, nrm, uvs = mesh
    m = uw.define_mesh(stage, path, pts, idx, nrm, uvs, **kwargs)
    uw.bind_material(m, material)
    return m


def camera(stage: Usd.Stage, name: str, eye, target, hfov_deg: float, resolution, clipping) -> UsdGeom.Camera:
    """``/World/Cameras/<name>``, +Y up."""
    return uw.define_camera(stage, f"/World/Cameras/{name}", eye, target, hfov_deg, resolution, clipping=clipping)


# ----------------------------------------------------------------------------- textures


def latlong_direction(width: int, height: int) -> np.ndarray:
    """World direction of each texel centre of a lat-long map (OpenEXR / UsdLux
    DomeLight convention: +Y up, left column longitude +pi, longitude 0 towards +Z,
    longitude +pi/2 towards +X, top row latitude +pi/2)."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    lon = np.pi - 2.0 * np.pi * u[None, :]
    lat = np.pi / 2.0 - np.pi * v[:, None]
    return np.stack(np.broadcast_arrays(np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)), axis=-1)


def sun_direction() -> np.ndarray:
    """Unit direction towards the sun disk painted into the sky map."""
    lon, lat = np.radians(SUN_LON_DEG), np.radians(SUN_LAT_DEG)
    return np.array([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)])


def sky_image() -> np.ndarray:
    """The metal scene's environment (H, W, 3) linear RGB: sky gradient, ground, four
    coloured patches on the horizon (red +Z, green +X, blue -Z, yellow -X), a sun disk."""
    w, h = SKY_SIZE
    d = latlong_direction(w, h)
    up = d[..., 1:2]
    zenith, horizon, ground = np.array([0.12, 0.3, 0.85]), np.array([0.95, 0.9, 0.8]), np.array([0.22, 0.2, 0.17])
    t = np.sqrt(np.clip(up, 0.0, 1.0))
    img = np.where(up >= 0.0, horizon * (1.0 - t) + zenith * t, ground * (1.0 - 0.6 * np.clip(-up, 0.0, 1.0)))
    lon = np.degrees(np.arctan2(d[..., 0], d[..., 2]))
    lat = np.degrees(np.arcsin(np.clip(d[..., 1], -1.0, 1.0)))
    patches = {0.0: (3.0, 0.15, 0.1), 90.0: (0.15, 2.5, 0.2), 180.0: (0.15, 0.35, 3.0), -90.0: (2.5, 2.1, 0.15)}
    for centre, colour in patches.items():
        dlon = (lon - centre + 180.0) % 360.0 - 180.0
        inside = (np.abs(dlon) < 15.0) & (lat > 1.0) & (lat < 20.0)
        img[inside] = colour
    cos_sun = d @ sun_direction()
    img[cos_sun > np.cos(np.radians(SUN_RADIUS_DEG))] = (100.0, 95.0, 85.0)
    return img.astype(np.float32)


def orientation_image(size: int = 64) -> np.ndarray:
    """An asymmetric test pattern (H, W, 3) uint8 RGB, row 0 at the top: a black 'F' on
    light grey, corner squares red (top-left), green (top-right), blue (bottom-left),
    yellow (bottom-right)."""
    img = np.full((size, size, 3), 200, dtype=np.uint8)
    s = size // 64
    img[10 * s : 54 * s, 16 * s : 24 * s] = 0
    img[10 * s : 18 * s, 16 * s : 48 * s] = 0
    img[28 * s : 35 * s, 16 * s : 40 * s] = 0
    c = 8 * s
    img[:c, :c] = (255, 0, 0)
    img[:c, -c:] = (0, 255, 0)
    img[-c:, :c] = (0, 0, 255)
    img[-c:, -c:] = (255, 230, 0)
    return img


def write_textures(out: Path) -> None:
    """Write textures/sky.hdr (Radiance RGBE) and textures/orientation.png."""
    tex = out / "textures"
    tex.mkdir(parents=True, exist_ok=True)
    for name, ext, image in (("sky", ".hdr", sky_image()), ("orientation", ".png", orientation_image())):
        ok, data = cv2.imencode(ext, np.ascontiguousarray(image[..., ::-1]))
        if not ok:
            raise RuntimeError(f"cannot encode {name}{ext}")
        atomic_write_bytes(tex / f"{name}{ext}", data.tobytes())


# ----------------------------------------------------------------------------- scenes


def cornell_glass(out: Path) -> None:
    """Cornell-style box (1 unit) with a solid glass sphere, a right-angle glass prism (total
    internal reflection), a mirror panel and a red tinted pane, lit by a ceiling RectLight
    (+ its emissive patch) and a SphereLight."""
    st = uw.new_stage(1.0, "Y", "Cornell-style box with glass, mirror and a tinted pane (CC0, scripts/make_scenes.py)")
    mat = {
        "White": uw.define_material(st, "/World/Looks/White", diffuse=(0.73, 0.73, 0.73), roughness=1.0),
        "Red": uw.define_material(st, "/World/Looks/Red", diffuse=(0.63, 0.065, 0.05), roughness=1.0),
        "Green": uw.define_material(st, "/World/Looks/Green", diffuse=(0.14, 0.45, 0.091), roughness=1.0),
        "Light": uw.define_material(
            st, "/World/Looks/Light", diffuse=(0.78, 0.78, 0.78), emissive=(15.0, 13.5, 11.25), roughness=1.0
        ),
        "Glass": uw.define_material(
            st, "/World/Looks/Glass", diffuse=(1.0, 1.0, 1.0), roughness=0.0, opacity=0.0, ior=1.5, custom_data=GLASS
        ),
        "Mirror": uw.define_material(
            st,
            "/World/Looks/Mirror",
            diffuse=(0.95, 0.95, 0.95),
            roughness=0.0,
            metallic=1.0,
            custom_data={"mirror": True},
        ),
        "RedPane": uw.define_material(
            st,
            "/World/Looks/RedPane",
            diffuse=(0.9, 0.1, 0.08),
            roughness=0.0,
            opacity=0.3,
            ior=1.5,
            custom_data={"transmission": 0.7, "transmissionColor": (0.9, 0.1, 0.08), "thinWalled": True},
        ),
    }
    walls = {
        "Floor": ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0), "White"),
        "Ceiling": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), "White"),
        "Back": ((0.0, 0.5, -0.5), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), "White"),
        "Left": ((-0.5, 0.5, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), "Red"),
        "Right": ((0.5, 0.5, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0), "Green"),
    }
    for name, (c, u, v, m) in walls.items():
        add_mesh(st, f"/World/Geom/{name}", quad(c, u, v), mat[m])
    add_mesh(st, "/World/Geom/LightPatch", quad((0.0, 0.998, 0.0), (0.3, 0.0, 0.0), (0.0, 0.0, 0.3)), mat["Light"])
    add_mesh(st, "/World/Geom/GlassSphere", sphere((-0.2, 0.18, 0.05), 0.18, 24, 48), mat["Glass"])
    glass_prism = prism((-0.45, -0.25), (-0.25, -0.25), (-0.45, -0.45), 0.0, 0.5)
    add_mesh(st, "/World/Geom/GlassPrism", glass_prism, mat["Glass"])
    add_mesh(st, "/World/Geom/MirrorPanel", box((0.22, 0.3, -0.28), (0.4, 0.6, 0.04), -30.0), mat["Mirror"])
    add_mesh(
        st,
        "/World/Geom/RedPane",
        quad((0.15, 0.15, 0.2), (0.3, 0.0, 0.0), (0.0, 0.3, 0.0)),
        mat["RedPane"],
        double_sided=True,
    )
    down = (0.0, -1.0, 0.0)
    uw.define_rect_light(st, "/World/Lights/CeilingRect", (0.0, 0.99, 0.0), down, 0.3, 0.3, 15.0, (1.0, 0.9, 0.75))
    uw.define_sphere_light(st, "/World/Lights/Bulb", (0.1, 0.85, -0.2), 0.02, 150.0, (1.0, 0.95, 0.9))
    camera(st, "Main", (0.0, 0.5, 1.95), (0.0, 0.45, 0.0), 40.0, (512, 512), (0.01, 100.0))
    uw.save_stage(st, out / "cornell_glass.usda")


def metal_env(out: Path) -> None:
    """A mirror-gold torus knot and a chrome roughness sweep on a ground plane under a
    lat-long sky (textures/sky.hdr) and a DistantLight aligned with its sun disk."""
    st = uw.new_stage(1.0, "Y", "Metal objects under an environment map (CC0, scripts/make_scenes.py)")
    ground = uw.define_material(st, "/World/Looks/Ground", diffuse=(0.35, 0.35, 0.35), roughness=0.8)
    gold = uw.define_material(
        st, "/World/Looks/Gold", diffuse=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.05, custom_data={"mirror": True}
    )
    add_mesh(st, "/World/Geom/Ground", quad((0.0, 0.0, 0.0), (8.0, 0.0, 0.0), (0.0, 0.0, -8.0)), ground)
    add_mesh(st, "/World/Geom/TorusKnot", torus_knot((0.0, 1.0, -0.6), 0.2, 0.09, segments=160, sides=10), gold)
    for k, rough in enumerate((0.0, 0.15, 0.3, 0.5, 0.8)):
        name = f"Chrome_r{int(round(rough * 100)):03d}"
        m = uw.define_material(
            st,
            f"/World/Looks/{name}",
            diffuse=(0.95, 0.94, 0.92),
            metallic=1.0,
            roughness=rough,
            custom_data={"mirror": rough < 0.15},
        )
        add_mesh(st, f"/World/Geom/Sphere_{k}", sphere((-1.0 + 0.5 * k, 0.22, 0.5), 0.22, 14, 28), m)
    uw.define_dome_light(st, "/World/Lights/Environment", 1.0, (1.0, 1.0, 1.0), "textures/sky.hdr")
    uw.define_distant_light(st, "/World/Lights/Sun", -sun_direction(), 3.0, (1.0, 0.95, 0.85))
    camera(st, "Main", (0.0, 1.35, 3.6), (0.0, 0.72, -0.2), 55.0, (640, 360), (0.05, 100.0))
    uw.save_stage(st, out / "metal_env.usda")


def _acne_plane() -> tuple[np.ndarray, ...]:
    """A 0.9-unit quad whose normal is 87 degrees away from the hard-cases sun."""
    to_light = -np.asarray(HARD_SUN, dtype=np.float64) / np.linalg.norm(HARD_SUN)
    t = np.array([0.0, 0.0, 1.0]) - to_light[2] * to_light
    t /= np.linalg.norm(t)
    n = np.cos(np.radians(87.0)) * to_light + np.sin(np.radians(87.0)) * t
    e1 = np.cross((0.0, 1.0, 0.0), n)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return quad((1.45, 0.55, 0.3), 0.9 * e1, 0.9 * e2)


def _needles_and_degenerates() -> tuple[np.ndarray, np.ndarray]:
    """Six 0.8-long, 1e-4-wide needles fanned upwards, then three zero-area triangles:
    collinear corners, a repeated index, all three corners the same vertex."""
    base = np.array([1.6, 0.05, -0.6])
    pts, idx = [], []
    for k, ang in enumerate(np.radians(np.linspace(-40.0, 40.0, 6))):
        d = np.array([np.sin(ang), np.cos(ang), 0.0])
        side = np.array([np.cos(ang), -np.sin(ang), 0.0]) * 0.5e-4
        pts += [base - side, base + side, base + 0.8 * d]
        idx.append([3 * k, 3 * k + 1, 3 * k + 2])
    n = len(pts)
    pts += [base + (0.25, 0.1, 0.0), base + (0.35, 0.1, 0.0), base + (0.5, 0.1, 0.0)]
    idx += [[n, n + 1, n + 2], [n, n, n + 1], [n + 2, n + 2, n + 2]]
    return np.asarray(pts), np.asarray(idx)


def _polygons() -> tuple[np.ndarray, list[int], list[int]]:
    """Three quads in a row (the middle one a hole) and a hexagon above them."""
    origin = np.array([-2.0, 0.1, -0.9])
    grid = [(x * 0.3, y * 0.3, 0.0) for y in (0, 1) for x in range(4)]
    hexagon = [(0.45 + 0.25 * np.cos(a), 0.7 + 0.25 * np.sin(a), 0.0) for a in np.radians(np.arange(0, 360, 60))]
    pts = np.asarray(grid + hexagon) + origin
    counts = [4, 4, 4, 6]
    flat = [0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6] + list(range(8, 14))
    return pts, counts, flat


def hard_cases(out: Path) -> None:
    """Numerical and topological hard cases (see scenes/README.md)."""
    st = uw.new_stage(1.0, "Y", "Numerical hard cases for the renderer (CC0, scripts/make_scenes.py)")
    specs = {
        "Ground": {"diffuse": (0.5, 0.5, 0.5), "roughness": 0.9},
        "Tiny": {"diffuse": (0.9, 0.4, 0.05)},
        "Blue": {"diffuse": (0.05, 0.2, 0.7), "roughness": 0.3},
        "Ivory": {"diffuse": (0.8, 0.78, 0.7)},
        "ZRed": {"diffuse": (0.8, 0.1, 0.1)},
        "ZBlue": {"diffuse": (0.1, 0.2, 0.8)},
        "Needle": {"diffuse": (0.9, 0.8, 0.1)},
        "SlabGlass": {"diffuse": (1.0, 1.0, 1.0), "roughness": 0.0, "opacity": 0.0, "ior": 1.5, "custom_data": GLASS},
        "OrientationTex": {"roughness": 0.8, "diffuse_texture": "textures/orientation.png"},
        "Acne": {"diffuse": (0.8, 0.8, 0.8), "roughness": 0.9},
        "Teal": {"diffuse": (0.1, 0.6, 0.55)},
        "Magenta": {"diffuse": (0.8, 0.1, 0.7)},
    }
    mat = {name: uw.define_material(st, f"/World/Looks/{name}", **kw) for name, kw in specs.items()}
    geom = "/World/Geom"
    x, y = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)

    add_mesh(st, f"{geom}/HugeGround", quad((0.0, 0.0, 0.0), (1.0e4, 0.0, 0.0), (0.0, 0.0, -1.0e4)), mat["Ground"])
    add_mesh(st, f"{geom}/TinyCube", box((0.0, 5.0e-4, 0.0), (1.0e-3,) * 3, 30.0), mat["Tiny"])

    probe = UsdGeom.Xform.Define(st, f"{geom}/Probe")
    add_mesh(st, f"{geom}/Probe/Ball", sphere((-1.3, 0.25, 0.6), 0.25, 16, 32), mat["Blue"])
    add_mesh(st, f"{geom}/Probe/Block", box((-0.75, 0.15, 0.75), (0.3, 0.3, 0.3), 20.0), mat["Ivory"])
    far = UsdGeom.Xform.Define(st, f"{geom}/FarCopy")
    far.GetPrim().GetReferences().AddInternalReference(probe.GetPath())
    far.AddTranslateOp().Set(Gf.Vec3d(1.0e5, 0.0, 0.0))
    add_mesh(st, f"{geom}/FarCopy/FarTile", quad((-1.0, 0.0, 0.6), (3.0, 0.0, 0.0), (0.0, 0.0, -3.0)), mat["Ground"])

    add_mesh(st, f"{geom}/ZFightA", quad((-0.5, 0.35, -1.2), np.multiply(x, 0.8), np.multiply(y, 0.5)), mat["ZRed"])
    add_mesh(st, f"{geom}/ZFightB", quad((-0.1, 0.55, -1.2), np.multiply(x, 0.8), np.multiply(y, 0.5)), mat["ZBlue"])

    pts, idx = _needles_and_degenerates()
    uw.bind_material(uw.define_mesh(st, f"{geom}/NeedlesAndDegenerates", pts, idx, double_sided=True), mat["Needle"])

    add_mesh(st, f"{geom}/ThinGlassSlab", box((0.55, 0.4, 0.3), (0.4, 0.5, 1.0e-3)), mat["SlabGlass"])
    orientation = quad((0.35, 0.45, -0.5), np.multiply(x, 0.5), np.multiply(y, 0.5))
    add_mesh(st, f"{geom}/Orientation", orientation, mat["OrientationTex"])
    add_mesh(st, f"{geom}/GrazingPlane", _acne_plane(), mat["Acne"])

    pts, counts, flat = _polygons()
    poly = uw.define_mesh(st, f"{geom}/Polygons", pts, flat, face_vertex_counts=counts, hole_indices=[1])
    uw.bind_material(poly, mat["Teal"])
    lh = np.array([[-2.0, 0.1, -0.2], [-2.0, 0.5, -0.2], [-1.5, 0.5, -0.2], [-1.5, 0.1, -0.2]])
    left = uw.define_mesh(st, f"{geom}/LeftHanded", lh, [[0, 1, 2], [0, 2, 3]], left_handed=True)
    uw.bind_material(left, mat["Magenta"])

    uw.define_distant_light(st, "/World/Lights/Sun", HARD_SUN, 3.0, (1.0, 0.97, 0.9))
    uw.define_dome_light(st, "/World/Lights/Sky", 0.3, (0.6, 0.75, 1.0))
    camera(st, "Main", (0.0, 1.4, 3.6), (0.0, 0.35, -0.2), 62.0, (640, 480), (0.01, 2.0e4))
    camera(st, "Far", (1.0e5 - 1.0, 0.9, 2.4), (1.0e5 - 1.05, 0.2, 0.65), 50.0, (640, 480), (0.01, 100.0))
    camera(st, "Tiny", (0.002, 0.0015, 0.003), (0.0, 4.0e-4, 0.0), 40.0, (640, 480), (1.0e-5, 1.0e4))
    uw.save_stage(st, out / "hard_cases.usda")


def textured_animated(out: Path) -> None:
    """A textured cube spinning about +Y (frames 0..48 at 24 fps) and an orbiting camera."""
    st = uw.new_stage(1.0, "Y", "Spinning textured cube with a moving camera (CC0, scripts/make_scenes.py)")
    uw.set_time_range(st, 0.0, 48.0, 24.0)
    ground = uw.define_material(st, "/World/Looks/Ground", diffuse=(0.45, 0.45, 0.45), roughness=0.9)
    add_mesh(st, "/World/Geom/Ground", quad((0.0, 0.0, 0.0), (4.0, 0.0, 0.0), (0.0, 0.0, -4.0)), ground)
    UsdGeom.Scope.Define(st, "/World/Anim")
    spinner = UsdGeom.Xform.Define(st, "/World/Anim/Cube")
    spinner.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.3, 0.0))
    rotate = spinner.AddRotateYOp()
    for frame in range(49):
        rotate.Set(7.5 * frame, Usd.TimeCode(frame))
    tex = uw.define_material(st, "/World/Looks/Orientation", roughness=0.6, diffuse_texture="textures/orientation.png")
    add_mesh(st, "/World/Anim/Cube/Mesh", box((0.0, 0.0, 0.0), (0.5, 0.5, 0.5)), tex)
    uw.define_distant_light(st, "/World/Lights/Sun", (-0.4, -1.0, -0.5), 2.5, (1.0, 0.96, 0.9))
    uw.define_dome_light(st, "/World/Lights/Sky", 0.4, (0.6, 0.75, 1.0))
    camera(st, "Main", (0.0, 1.0, 2.2), (0.0, 0.3, 0.0), 50.0, (640, 480), (0.01, 100.0))
    anim = camera(st, "AnimCam", (0.0, 1.0, 2.2), (0.0, 0.3, 0.0), 50.0, (640, 480), (0.01, 100.0))
    keys = []
    for frame in range(49):
        a = np.radians(-40.0 + 80.0 * frame / 48.0)
        keys.append((frame, (2.2 * np.sin(a), 0.8 + 0.4 * frame / 48.0, 2.2 * np.cos(a)), (0.0, 0.3, 0.0)))
    uw.animate_look_at(anim, keys)
    uw.save_stage(st, out / "textured_animated.usda")


SCENES = (cornell_glass, metal_env, hard_cases, textured_animated)


def main(argv: list[str] | None = None) -> int:
    """Command line entry: write every scene and texture into OUT_DIR."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", nargs="?", default=str(ROOT / "scenes"), help="output folder (default: scenes/)")
    out = Path(parser.parse_args(argv).out_dir)
    write_textures(out)
    for make in SCENES:
        make(out)
    for path in sorted(out.rglob("*")):
        if path.is_file() and path.suffix in (".usda", ".hdr", ".png"):
            print(f"{path.relative_to(out)}: {path.stat().st_size / 1024:.1f} KiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
