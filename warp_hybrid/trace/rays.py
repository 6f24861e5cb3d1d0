"""What every traced ray shares: per-frame parameters, hits, and stepping past a surface.

Ray origins are offset with ``offset.offset_ray_origin`` along the geometric normal,
to the side the ray travels to, by the error bound of the hit's own triangle
(``offset.hit_bound``).  Pixel lists
hold flat indices ``row * width + column``.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBufferArrays
from ..core.scene_gpu import SceneGPU
from .occluders import OccluderGPU
from .offset import hit_bound, offset_ray_origin

MIN_THROUGHPUT = wp.constant(1.0e-3)
MAX_LAYERS = wp.constant(64)


@wp.struct
class TraceParams:
    """Per-frame constants: path depth, shadow samples, seed (ray offsets need none:
    ``offset.hit_bound`` bounds each hit on its own)."""

    max_depth: int
    shadow_samples: int
    seed: int


@wp.struct
class TraceFrame:
    """What both tracing kernels share in one call: the camera, the parameters, the
    shadow BVHs, the G-buffer, the pixel list, and the per-item scratch rows (RGB
    transmittance per light, ray counts per kind)."""

    cam: CameraGPU
    params: TraceParams
    occ: OccluderGPU
    gb: GBufferArrays
    pixels: wp.array(dtype=wp.int32)
    transmittance: wp.array2d(dtype=wp.vec3)
    counts: wp.array2d(dtype=wp.int32)


@wp.struct
class RayHit:
    """Closest surface along a ray (``face`` -1: none)."""

    face: int
    u: float
    v: float


@wp.func
def max3(c: wp.vec3) -> float:
    """Largest component."""
    return wp.max(c[0], wp.max(c[1], c[2]))


@wp.func
def triangle_position(scene: SceneGPU, face: int, u: float, v: float) -> wp.vec3:
    """World point at barycentrics (u, v) of ``face`` (Warp's convention)."""
    k = 3 * face
    return (
        scene.points[scene.indices[k]] * u
        + scene.points[scene.indices[k + 1]] * v
        + scene.points[scene.indices[k + 2]] * (1.0 - u - v)
    )


@wp.func
def step_past(scene: SceneGPU, face: int, u: float, v: float, ng: wp.vec3, d: wp.vec3) -> wp.vec3:
    """Origin just beyond the surface hit at (face, u, v), on the side ``d`` travels to."""
    n = ng
    if wp.dot(n, d) < 0.0:
        n = -n
    return offset_ray_origin(triangle_position(scene, face, u, v), n, hit_bound(scene, face))
