"""The dome where the path kernel's rays leave the scene, across a group of its items.

``path.begin_item`` gave a pixel that sees no surface the dome's radiance along its
camera ray (``environment_radiance``), and ``path.finish_item`` a ray that escapes the
dome's radiance along it, one ray at a time: the direction's two lat-long arctangents
and the bilinear footprint, scalar. On Suzanne's full frame (40% background) the
background alone was 8-13 of the path kernel's 75-80 ms on one thread, the escaping
first rays (its chrome's reflections) about another 4%. Here the group's camera rays
(``group_background``) and its first rays that the packet query found to miss
(``first_ray_sky``) are looked up across the group (vectorised: straight-line
arithmetic over lane arrays), only the texel loads and their blend lane by lane. The
same lambdas as the scalar lookup (``environment.ENVIRONMENT_LAMBDAS_CPP``, the camera
ray's ``CAMERA_RAY_CPP``), in the same module, so the same bits.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CAMERA_RAY_CPP
from ..core.native_rows import WH_AT_CPP
from ..core.pixel_list import listed_pixel_cpp
from ..core.scene_gpu import SceneGPU
from ..lighting.native_math import cpp
from ..parallel import ITEM_GROUP
from ..scene.device.environment import dome_along_lanes_cpp
from .rays import TraceFrame

#: One launch item's dome radiance (along its background's camera rays, or its first rays): row
#: ``k`` for its ``k``-th item.
GroupRadiance = wp.types.matrix(shape=(ITEM_GROUP, 3), dtype=wp.float32)
#: One launch item's first rays' directions (row ``k``: its ``k``-th item's), their packet
#: query's answers (``wide_bvh.hit_from_row``'s rows: column 7 is 1 for a hit) and which
#: items' first rays were queried.
GroupDirections = wp.types.matrix(shape=(ITEM_GROUP, 3), dtype=wp.float32)
GroupHits = wp.types.matrix(shape=(ITEM_GROUP, 8), dtype=wp.float32)
GroupFlags = wp.types.vector(length=ITEM_GROUP, dtype=wp.int32)


def _dome_along_cpp(lanes: str, wanted: str, direction: str) -> str:
    """C++ that ends a group function: ``out``'s first ``lanes`` rows where ``wanted`` (a
    condition on lane ``j``, ``count`` lanes in all) hold the dome's radiance along
    ``direction`` (a C++ expression of lane ``j``'s world direction, any length):
    ``environment_radiance``'s arithmetic, its uvs and footprints across all the lanes,
    the texel loads only where wanted (``environment.dome_along_lanes_cpp``)."""
    store = "out.data[j][0] = c[0]; out.data[j][1] = c[1]; out.data[j][2] = c[2];"
    return f"""
if (count == 0) return out;
if (env.texture < 0) {{
    for (int j = 0; j < {lanes}; ++j) {{
        out.data[j][0] = env.color[0]; out.data[j][1] = env.color[1]; out.data[j][2] = env.color[2];
    }}
    return out;
}}{dome_along_lanes_cpp("G", lanes, direction, wanted, store)}
return out;
"""


_GROUP_CPP = (
    cpp("environment")
    + WH_AT_CPP
    + f"""
constexpr int G = {ITEM_GROUP};
const auto cam = tf.cam;
auto wh_pixel_ray = [&](const float px, const float py) WH_INLINE -> wp::vec3 {{
{CAMERA_RAY_CPP}
    return ray;
}};
const auto& env = scene.environment;
wp::mat_t<G, 3, float> out;
if (env.enabled == 0) return out;
const int n = stop - first < G ? stop - first : G;
const int width = cam.width;
const int pixels = width * cam.height;
float sx[G], sy[G];
bool background[G];
int count = 0;
for (int j = 0; j < n; ++j) {{
    {listed_pixel_cpp("tf.pixels.data[first + j]")}
    background[j] = inside && wh_at(tf.gb.triangle_id, y, x) < 0;
    count += background[j] ? 1 : 0;
    sx[j] = wp::add((float)x, cam.sample[0]);
    sy[j] = wp::add((float)y, cam.sample[1]);
}}"""
    + _dome_along_cpp("n", "background[j]", "wh_normalize(wh_pixel_ray(sx[j], sy[j]))")
)


@wp.func_native(_GROUP_CPP)
def group_background(scene: SceneGPU, tf: TraceFrame, first: int, stop: int) -> GroupRadiance:
    """Row ``k``: where pixel-list item ``first + k`` (``first <= first + k < stop``, at
    most ``ITEM_GROUP`` items) is a pixel that sees no surface, the dome's radiance along
    its camera ray (``environment_radiance(scene, pixel_ray_direction(tf.cam, x, y))``,
    bit for bit; black without a dome).  The rows of other items hold values nobody
    reads."""
    ...


_SKY_CPP = (
    cpp("environment")
    + f"""
constexpr int G = {ITEM_GROUP};
const auto& env = scene.environment;
wp::mat_t<G, 3, float> out;
if (env.enabled == 0) return out;
bool miss[G];
int count = 0;
for (int j = 0; j < G; ++j) {{
    miss[j] = queried[j] != 0 && !(hits.data[j][7] > 0.0f);
    count += miss[j] ? 1 : 0;
}}"""
    + _dome_along_cpp("G", "miss[j]", "wp::vec3(directions.data[j][0], directions.data[j][1], directions.data[j][2])")
)


@wp.func_native(_SKY_CPP)
def first_ray_sky(scene: SceneGPU, directions: GroupDirections, hits: GroupHits, queried: GroupFlags) -> GroupRadiance:
    """Row ``k``: where item ``k``'s first ray was queried (``queried[k]`` non-zero) and
    missed (``hits[k]``), the dome's radiance along ``directions[k]``
    (``environment_radiance``, bit for bit; black without a dome).  Other rows hold
    values nobody reads."""
    ...
