"""The traced primary points' dome terms, across a group of the path kernel's items: the
diffuse ambient light (``ambient.ambient_diffuse``: the dome's SH irradiance, plus the
lights' indirect estimate) and the glossy reflection of the dome
(``ambient.ambient_specular``: the prefiltered mip chain along the mirror direction
times the split-sum reflectance), which ``path.shade_hit`` adds at segment 0.

``shade_hit`` looked both up point by point: the SH sum, the lat-long arctangents, the
lobe's level and each bilinear footprint, scalar; on Suzanne's full frame the glossy term
alone was about a fifth of the path kernel (its floor and rough spheres). Here the
deferred pass's row-loop pieces (``lighting/direct_rows.py``: ``dome_terms_cpp``, the
same lambdas, the same bits as the scalar lookups) run over the group's pixels, gathered
through the pixel list: the arithmetic across lanes, only the texel loads lane by lane,
and those only where the glossy term is likely to be added (``GLOSSY_LANE_CPP``: the mirror
ray carries less than the whole reflection); ``shade_hit`` looks up the others itself
where it needs them (column ``HAS_GLOSSY`` says which lanes have it).
"""

from __future__ import annotations

import warp as wp

from ..core.constants import GLOSSY_ROUGHNESS
from ..core.native_rows import CHUNK_CPP, WH_AT_CPP, float_literal
from ..core.scene_gpu import AmbientGPU, SceneGPU
from ..lighting.direct_rows import DOME_LANES_CPP, LANE_ARRAYS_CPP, dome_terms_cpp, view_cpp
from ..lighting.native_math import cpp
from ..parallel import ITEM_GROUP
from .primary_light import GROUP_FRAME_CPP, TRACED_KD_CPP, group_gather_cpp
from .rays import TraceFrame

#: Columns of a group's row: the diffuse ambient term, the glossy one, and 1 where the
#: glossy one was looked up (0: ``shade_hit`` looks it up itself if it adds it).
#: (Each vec3 at a multiple of four floats: the path kernel copies an item's row out and
#: reads it back at once, and a read that straddled two of the copy's stores waited for
#: them, a failed store-to-load forward the line profile showed with rows of seven.)
DIFFUSE = wp.constant(0)
GLOSSY = wp.constant(4)
HAS_GLOSSY = wp.constant(7)
ROW_FLOATS = 8
GroupDome = wp.types.matrix(shape=(ITEM_GROUP, ROW_FLOATS), dtype=wp.float32)
#: One item's row of a ``GroupDome``.
DomeRow = wp.types.vector(length=ROW_FLOATS, dtype=wp.float32)

#: Which lanes look the glossy term up: those whose mirror ray carries less than the whole
#: reflection (``mirror_share`` < 1 above ``GLOSSY_ROUGHNESS``), where ``shade_hit`` adds
#: the term for every material (a smoother one adds it only without a mirror ray).
GLOSSY_LANE_CPP = f"rough[j] > {float_literal(float(GLOSSY_ROUGHNESS))}"
#: A lane's ``hit``: it looks the glossy lobe up.
_GLOSSY_HIT_CPP = f"""
        hit[j] = glossy && inside && wh_at(gb.triangle_id, y, x) >= 0 && {GLOSSY_LANE_CPP};"""

_GROUP_CPP = (
    CHUNK_CPP
    + cpp("diffuse_albedo", "env_brdf", "ambient_irradiance", "ambient_diffuse", "prefiltered_radiance")
    + WH_AT_CPP
    + GROUP_FRAME_CPP
    + f"""
wp::mat_t<{ITEM_GROUP}, {ROW_FLOATS}, float> out;
if (!traced) return out;  // (at max depth 0 ``shade_hit`` shades the primary point as the raster does)
{LANE_ARRAYS_CPP}{DOME_LANES_CPP}
const int end = stop - first < {ITEM_GROUP} ? stop : first + {ITEM_GROUP};  // (never more rows than ``out`` has)
for (int xs = first; xs < end; xs += CHUNK) {{
    const int n = end - xs < CHUNK ? end - xs : CHUNK;{group_gather_cpp(_GLOSSY_HIT_CPP)}
{view_cpp(TRACED_KD_CPP)}
    if (uniform_dome) {{  // (the same irradiance and radiance for every lane)
        for (int j = 0; j < n; ++j) {{
            ir[j] = e_free[0]; ig[j] = e_free[1]; ib[j] = e_free[2];
            sr[j] = sky[0]; sg[j] = sky[1]; sb[j] = sky[2];
        }}
    }} else {{{dome_terms_cpp(raster=False)}    }}
    for (int j = 0; j < n; ++j) {{
        const wp::vec3 nn(nx[j], ny[j], nz[j]);
        const wp::vec3 v(vx[j], vy[j], vz[j]);
        const wp::vec3 f0(fr[j], fg[j], fb[j]);
        const wp::vec3 diffuse = wh_ambient_diffuse(false, wp::vec3(ir[j], ig[j], ib[j]), nn, v,
                                                    wp::vec3(kr[j], kg[j], kb[j]), f0);
        const wp::vec3 specular = wh_select(amb.enabled != 0, wp::cw_mul(wh_env_brdf(amb.brdf_lut, f0, rough[j],
                                                                                     wp::dot(nn, v)),
                                                                         wp::vec3(sr[j], sg[j], sb[j])),
                                            wp::vec3(0.0f));
        float* row = out.data[xs - first + j];
        row[{DIFFUSE}] = diffuse[0]; row[{DIFFUSE} + 1] = diffuse[1]; row[{DIFFUSE} + 2] = diffuse[2];
        row[{GLOSSY}] = specular[0]; row[{GLOSSY} + 1] = specular[1]; row[{GLOSSY} + 2] = specular[2];
        row[{HAS_GLOSSY}] = hit[j] ? 1.0f : 0.0f;
    }}
}}
return out;
"""
)


@wp.func_native(_GROUP_CPP)
def primary_dome(
    scene: SceneGPU, amb: AmbientGPU, tf: TraceFrame, first: int, stop: int, transparency: bool, glossy: bool
) -> GroupDome:
    """Row ``k``, for pixel-list item ``first + k`` (``first <= first + k < stop``, at most
    ``ITEM_GROUP`` items) where it is a hit pixel and ``max_depth`` > 0: at ``DIFFUSE`` its
    primary point's ``ambient_diffuse`` (with the diffuse colour ``shade_hit`` gives a
    primary hit, ``transparency``: the variant models transmissive materials), at
    ``GLOSSY`` its ``ambient_specular`` where ``HAS_GLOSSY`` is 1 (with ``glossy``, on the
    lanes ``GLOSSY_LANE_CPP`` picks), bit for bit the scalar functions' values.  The rows
    of other items hold values nobody reads."""
    ...


@wp.func
def dome_diffuse(row: DomeRow) -> wp.vec3:
    """The diffuse ambient term of a ``primary_dome`` row."""
    return wp.vec3(row[DIFFUSE], row[DIFFUSE + 1], row[DIFFUSE + 2])


@wp.func
def dome_glossy(row: DomeRow) -> wp.vec3:
    """The glossy term of a ``primary_dome`` row (where ``HAS_GLOSSY`` is 1)."""
    return wp.vec3(row[GLOSSY], row[GLOSSY + 1], row[GLOSSY + 2])
