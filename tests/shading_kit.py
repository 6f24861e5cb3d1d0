"""Shading points for the tests of the row loops (the deferred pass's, and the tracer's primary
direct light and background): one light of every kind over a random G-buffer under a rect
light, and domes of every kind."""

from __future__ import annotations

import numpy as np

from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.scene.model import Environment, Light, LightKind, TextureBinding, TextureImage

#: Where the rect light hangs, facing down over the points.
RECT_CENTRE = (0.0, 2.0, 0.0)


def light_set(kind: str) -> list[Light]:
    """One light of ``kind`` ("rect": a rectangle facing down over the points; "all": one
    of every kind, a spot among them)."""
    rect = Light(
        LightKind.RECT,
        "rect",
        (3.0, 2.5, 2.0),
        position=RECT_CENTRE,
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.5, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.4),
    )
    if kind == "rect":
        return [rect]
    return [
        rect,
        Light(LightKind.DISTANT, "sun", (1.0, 0.9, 0.8), direction=(0.3, -1.0, 0.2)),
        Light(LightKind.SPHERE, "bulb", (5.0, 5.0, 5.0), position=(1.0, 1.5, 1.0), radius=0.2, normalize=True),
        Light(LightKind.SPHERE, "point", (2.0, 1.0, 1.0), position=(-1.0, 1.0, 0.5)),
        Light(
            LightKind.SPHERE,
            "spot",
            (8.0, 8.0, 8.0),
            position=(0.0, 3.0, 1.0),
            direction=(0.0, -1.0, 0.0),
            radius=0.1,
            cone_angle_deg=30.0,
            cone_softness=0.5,
        ),
        Light(
            LightKind.DISK,
            "disk",
            (4.0, 4.0, 4.0),
            position=(-1.5, 2.0, -1.0),
            direction=(0.2, -1.0, 0.0),
            radius=0.3,
        ),
    ]


def gbuffer_under_rect(device: str, rng: np.random.Generator, width: int, height: int) -> GBuffer:
    """Points below the rect light; row 0 faces it (the rectangle above every horizon),
    row 1 faces sideways under it (the horizon cuts it at every pixel), the other rows
    have random normals (a mix); random colours, roughness 0.15-1 (in row 0 in runs of
    five pixels), every third pixel glass (material 1) but in row 0, every pixel on
    triangle 0."""
    h, w = height, width
    gb = GBuffer(w, h, device)
    pos = np.zeros((h, w, 3), np.float32)
    pos[..., 0] = rng.uniform(-2.0, 2.0, (h, w))
    pos[1, :, 0] = rng.uniform(-0.3, 0.3, w)
    pos[..., 1] = rng.uniform(-0.2, 0.2, (h, w))
    pos[..., 2] = rng.uniform(-0.3, 0.3, (h, w))
    normal = rng.normal(size=(h, w, 3)).astype(np.float32)
    normal[0] = (0.0, 1.0, 0.0)
    normal[1] = (1.0, 0.0, 0.0)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    gb.position.assign(pos)
    gb.normal.assign(normal)
    gb.albedo.assign(rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32))
    gb.specular.assign(rng.uniform(0.0, 1.0, (h, w, 3)).astype(np.float32))
    optics = np.zeros((h, w), dtype=gb.optics.numpy().dtype)
    optics["roughness"] = rng.uniform(0.15, 1.0, (h, w))
    optics["roughness"][0] = np.repeat(rng.uniform(0.15, 1.0, -(-w // 5)), 5)[:w]  # (runs, as a material's pixels)
    optics["opacity"] = rng.uniform(0.0, 1.0, (h, w))
    optics["ior"] = rng.uniform(1.2, 2.0, (h, w))
    gb.optics.assign(optics)
    glass = np.arange(h * w).reshape(h, w) % 3 == 0
    glass[0] = False  # (row 0: no transmissive pixel, as most of a scene's rows)
    gb.material_id.assign(glass.astype(np.int32))
    gb.triangle_id.assign(np.zeros((h, w), np.int32))
    return gb


def dome_arguments(kind: str, rng: np.random.Generator) -> dict:
    """``make_scene`` arguments for no dome ("none"), a constant one ("constant") or one
    with a random 32x64 lat-long texture ("textured": scaled and biased, three mip levels,
    every SH band)."""
    if kind == "none":
        return {}
    if kind == "constant":
        return {"environment": Environment("dome", (0.2, 0.3, 0.4))}
    pixels = rng.uniform(0.0, 2.0, (32, 64, 4)).astype(np.float32)
    return {
        "environment": Environment("dome", (0.9, 1.0, 1.1), texture=0),
        "textures": [TextureBinding(0, scale=(1.5, 0.5, 1.0, 1.0), bias=(0.0, 0.25, 0.1, 0.0))],
        "images": [TextureImage("<sky>", pixels)],
    }
