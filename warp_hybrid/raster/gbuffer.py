"""The G-buffer: per-pixel surface attributes of the nearest visible surface.

Both primary-visibility paths (raster and ray cast) fill the same ``GBuffer``, so the
lighting, tracing and composition stages never know which one ran.  Arrays are
indexed ``[row, column]`` with row 0 at the top.  Background pixels have
``triangle_id == -1``; their float attributes are left at the values ``clear`` writes
(depth = +inf, the rest 0); ``aovs()`` turns them into the AOV contract (NaN).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import warp as wp


@dataclass
class GBuffer:
    """Device arrays, each (height, width).

    position: world-space hit point.  normal: unit shading normal, flipped to face the
    camera.  geometric_normal: unit face normal, facing the camera (ray offsets use it).
    depth: view depth along the camera forward axis (+inf for background).
    albedo: diffuse colour (linear, textures applied, times (1 - metallic)).
    specular: specular F0 colour.  emission: emitted radiance.
    optics: (reflectivity, ior, opacity, roughness); reflectivity is the Fresnel
    reflectance at normal incidence (luminance of F0).
    material_id / triangle_id: -1 for background.
    barycentric: Warp's (u, v) of the hit on ``triangle_id`` (the visibility record the
    surface pass evaluates attributes from).
    """

    width: int
    height: int
    position: wp.array
    normal: wp.array
    geometric_normal: wp.array
    depth: wp.array
    albedo: wp.array
    specular: wp.array
    emission: wp.array
    optics: wp.array
    material_id: wp.array
    triangle_id: wp.array
    barycentric: wp.array

    @staticmethod
    def allocate(width: int, height: int, device: wp.context.Device | str) -> GBuffer:
        """Allocate an empty G-buffer on ``device``."""
        shape = (height, width)

        def v3() -> wp.array:
            return wp.zeros(shape, dtype=wp.vec3, device=device)

        return GBuffer(
            width=width,
            height=height,
            position=v3(),
            normal=v3(),
            geometric_normal=v3(),
            depth=wp.full(shape, value=float("inf"), dtype=wp.float32, device=device),
            albedo=v3(),
            specular=v3(),
            emission=v3(),
            optics=wp.zeros(shape, dtype=wp.vec4, device=device),
            material_id=wp.full(shape, value=-1, dtype=wp.int32, device=device),
            triangle_id=wp.full(shape, value=-1, dtype=wp.int32, device=device),
            barycentric=wp.zeros(shape, dtype=wp.vec2, device=device),
        )

    def arrays(self) -> dict[str, wp.array]:
        """Every per-pixel array by field name (the one list the kernel-side structs
        and ``clear`` are built from)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("width", "height")}

    def clear(self) -> None:
        """Reset to background: depth +inf, ids -1, everything else 0."""
        self.depth.fill_(float("inf"))
        self.material_id.fill_(-1)
        self.triangle_id.fill_(-1)
        for name, array in self.arrays().items():
            if name not in ("depth", "material_id", "triangle_id"):
                array.zero_()

    def hit_mask(self) -> np.ndarray:
        """(H, W) bool: True where a surface was hit."""
        return self.triangle_id.numpy() >= 0

    def aovs(self) -> dict[str, np.ndarray]:
        """Host copies in the AOV contract: depth (+inf on background), position,
        normal (NaN on background), albedo (0 on background)."""
        hit = self.hit_mask()
        depth = self.depth.numpy().astype(np.float32)
        depth[~hit] = np.inf
        position = self.position.numpy().astype(np.float32)
        position[~hit] = np.nan
        normal = self.normal.numpy().astype(np.float32)
        normal[~hit] = np.nan
        albedo = self.albedo.numpy().astype(np.float32)
        albedo[~hit] = 0.0
        return {"depth": depth, "position": position, "normal": normal, "albedo": albedo}
