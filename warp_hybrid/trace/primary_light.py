"""The traced primary points' direct light, across pixels: the lights' sum at the first
hit of a group of the path kernel's items, each light's unshadowed response times the
transmittance the shadow kernel left (``path.shade_hit`` at segment 0).

The path kernel computed that sum point by point (``light_sample`` and
``light_response`` per light); on a scene whose rays mostly end at the first hit (the
Cornell box: no mirror, no glass) it was nearly the whole kernel. Here the deferred
pass's row loop (``lighting/direct_rows.py``: the same lambdas, vectorised across the
chunk's pixels, the same bits as the scalar functions) runs over the group's pixels,
gathered through the pixel list, with the traced diffuse colour (the albedo, times the
opacity for a transmissive material where the variant models transparency; the raster's
colour where ``max_depth`` is 0 and the primary hit is shaded as the raster shades it)
and each term multiplied by its transmittance before it is added, in light order, as
``shade_hit`` adds them.
"""

from __future__ import annotations

import warp as wp

from ..core.native_rows import CHUNK_CPP, WH_AT_CPP
from ..core.pixel_list import listed_pixel_cpp
from ..core.scene_gpu import FLAG_TRANSMISSIVE, SceneGPU
from ..lighting.direct_rows import LANE_ARRAYS_CPP, RASTER_KD_CPP, lane_fill_cpp, light_loop_cpp, view_cpp
from ..lighting.native_math import cpp
from ..parallel import ITEM_GROUP
from .rays import TraceFrame

#: One launch item's primary direct light: row ``k`` for its ``k``-th item.
GroupDirect = wp.types.matrix(shape=(ITEM_GROUP, 3), dtype=wp.float32)

#: The diffuse colour ``shade_hit`` gives a primary hit (also ``primary_dome``) (``traced``: ``max_depth`` > 0).
TRACED_KD_CPP = f"""traced ? wh_select(transparency && (flags[j] & {int(FLAG_TRANSMISSIVE)}) != 0,
                                   wp::mul(wp::vec3(ar[j], ag[j], ab[j]), opac[j]), wp::vec3(ar[j], ag[j], ab[j]))
                       : {RASTER_KD_CPP}"""

#: Each light's term times the item's transmittance toward it (``direct += cw_mul(c, tr)``:
#: one Warp operation a call, so nothing is fused).
_SHADOWED_SUM_CPP = """
        for (int j = 0; j < n; ++j) {
            const wp::vec3 t = wh_at(tf.transmittance, xs + j, li);
            const wp::vec3 d = wp::add(wp::vec3(dr[j], dg[j], db[j]), wp::cw_mul(wp::vec3(cr[j], cg[j], cb[j]), t));
            dr[j] = d[0]; dg[j] = d[1]; db[j] = d[2];
        }"""

#: A group function's frame (``tf`` its ``TraceFrame``): the G-buffer, the image's size,
#: whether there is a dome, whether paths go past the primary point, the eye.
GROUP_FRAME_CPP = """
const auto& gb = tf.gb;
const int width = tf.cam.width;
const int pixels = width * tf.cam.height;
const bool dome = scene.environment.enabled != 0;
const bool traced = tf.params.max_depth > 0;
const wp::vec3 eye = tf.cam.origin;
"""


def group_gather_cpp(lane: str = "") -> str:
    """C++ of a group function's step (1): for each lane ``j`` of the chunk from list
    item ``xs``, its pixel (``inside``: in the image; an entry outside reads pixel 0, whose
    values are not used), its G-buffer channels into the lane arrays, then the statements
    ``lane`` (given ``inside``, ``x`` and ``y``)."""
    fill = lane_fill_cpp(
        *(f"wh_at(gb.{name}, y, x)" for name in ("position", "normal", "albedo", "specular", "optics", "material_id"))
    )
    return f"""
    for (int j = 0; j < n; ++j) {{
        {listed_pixel_cpp("tf.pixels.data[xs + j]")}
{fill}{lane}
    }}"""


_GROUP_CPP = (
    CHUNK_CPP
    + cpp("light_sample", "light_response", "diffuse_albedo")
    + WH_AT_CPP
    + GROUP_FRAME_CPP
    + f"""
const int lights_begin = 0;
const int lights_end = scene.light_count;
wp::mat_t<{ITEM_GROUP}, 3, float> out;
{LANE_ARRAYS_CPP}
const int end = stop - first < {ITEM_GROUP} ? stop : first + {ITEM_GROUP};  // (never more rows than ``out`` has)
for (int xs = first; xs < end; xs += CHUNK) {{
    const int n = end - xs < CHUNK ? end - xs : CHUNK;{group_gather_cpp()}
{view_cpp(TRACED_KD_CPP)}{light_loop_cpp(_SHADOWED_SUM_CPP)}
    for (int j = 0; j < n; ++j) {{
        out.data[xs - first + j][0] = dr[j]; out.data[xs - first + j][1] = dg[j]; out.data[xs - first + j][2] = db[j];
    }}
}}
return out;
"""
)


@wp.func_native(_GROUP_CPP)
def primary_direct(scene: SceneGPU, tf: TraceFrame, first: int, stop: int, transparency: bool) -> GroupDirect:
    """Row ``k``: the direct light at the primary point of pixel-list item ``first + k``
    (``first <= first + k < stop``, at most ``ITEM_GROUP`` items): the sum over the scene's
    lights of each one's response (``light_sample``, ``light_response``) times
    ``tf.transmittance[item, light]``, in light order, with the diffuse colour
    ``shade_hit`` gives a primary hit (``transparency``: the variant models transmissive
    materials).  The rows of items that are not a hit pixel hold values nobody reads."""
    ...
