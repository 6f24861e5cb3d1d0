"""The deferred pass's lighting as native row loops, across pixels: ``direct_span``, the
lights' unshadowed responses (``shading.direct_light``, summed over a range of the
scene's lights: all of them, or one at a time where shadow maps weigh each) for a span
of one row; ``lit_span``, the pixels' whole radiance (``shading.shade_surface`` over
that sum with the dome's ambient terms, the dome's radiance where no surface is hit).

The loop takes ``CHUNK_CPU`` pixels at a time: (1) a gather of the pixels' G-buffer
channels and material flags, (2) the view direction and the diffuse colour
(``wh_diffuse_albedo``), then for each light (3) its sample and response
(``native_math``) as straight-line arithmetic over the chunk, the light's kind a literal
and its cone decided once (the compiler vectorises this across pixels; a rect light's
chunk takes the short path where the rectangle lies above every pixel's horizon, the
clipped polygon where it lies above none, both and a choice per pixel where it is
mixed), and (4) the sum, or in ``lit_span`` the pixel's radiance: under a dome whose
light is the same from every direction (``ambient.direction_free``: none, or an
untextured one) from one irradiance and one radiance for the row; under a textured one
the SH irradiance at each normal, the lat-long uvs each pixel reads, the mip levels it
blends and each bilinear fetch's texel indices and weights vectorised too, and the
texel loads and their blend (the prefiltered mip chain, the dome behind glass, the
background) pixel by pixel, a texel one 16-byte load; then ``wh_surface_radiance`` with the split-sum
``wh_env_brdf`` across pixels again.  The same lambdas as the scalar functions, so the same arithmetic; in
``direct_span`` background pixels get a value the caller ignores.  The loop's pieces
(the lane arrays, a lane's fill, steps (2) and (3) with their diffuse colour and sum
as parameters) also build the tracer's primary direct light (``trace/primary_light.py``),
and step (4)'s dome lookups its primary points' dome terms (``trace/primary_dome.py``).
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CAMERA_RAY_CPP, CameraGPU
from ..core.gbuffer import GBufferArrays
from ..core.native_rows import CHUNK_CPP, STREAM_CPP, row_cpp
from ..core.scene_gpu import FLAG_TRANSMISSIVE, AmbientGPU, SceneGPU
from ..post.exposure import LOG_COUNTS_CPP, LOG_FLOAT_CPP, LOG_LUMINANCE_CPP, LOG_TERM_CPP
from ..scene.device.environment import dome_along_lanes_cpp, texel_gather_cpp
from .native_math import cpp

#: (1) the lane arrays of a chunk: point, normal, view direction, albedo, diffuse colour,
#: specular colour, optics, the light's sum and one light's term, material flags.
LANE_ARRAYS_CPP = """float px[CHUNK], py[CHUNK], pz[CHUNK], nx[CHUNK], ny[CHUNK], nz[CHUNK], vx[CHUNK], vy[CHUNK], vz[CHUNK];
float ar[CHUNK], ag[CHUNK], ab[CHUNK], kr[CHUNK], kg[CHUNK], kb[CHUNK], fr[CHUNK], fg[CHUNK], fb[CHUNK];
float rough[CHUNK], opac[CHUNK], ior[CHUNK], dr[CHUNK], dg[CHUNK], db[CHUNK], cr[CHUNK], cg[CHUNK], cb[CHUNK];
int flags[CHUNK];"""


def lane_fill_cpp(position: str, normal: str, albedo: str, specular: str, optics: str, material: str) -> str:
    """C++ of (1) for lane ``j``: its G-buffer channels (C++ expressions of the pixel's
    point, normal, albedo, specular colour, optics record and material id) into the lane
    arrays, and its material's flags (0 without one)."""
    return f"""        const wp::vec3 p = {position}, nn = {normal}, a = {albedo}, f = {specular};
        px[j] = p[0]; py[j] = p[1]; pz[j] = p[2];
        nx[j] = nn[0]; ny[j] = nn[1]; nz[j] = nn[2];
        ar[j] = a[0]; ag[j] = a[1]; ab[j] = a[2];
        fr[j] = f[0]; fg[j] = f[1]; fb[j] = f[2];
        rough[j] = {optics}.roughness;
        opac[j] = {optics}.opacity;
        ior[j] = {optics}.ior;
        const int mid = {material};
        flags[j] = mid >= 0 ? scene.materials.data[mid].flags : 0;"""


# (2) the view direction and the diffuse colour of the chunk's pixels (``kd``: the C++
# expression of the diffuse colour, given ``nn``, ``v`` and the lane arrays), the sums
# zeroed; ``glass_lanes``, how many of the chunk's pixels are transmissive.
def view_cpp(kd: str) -> str:
    """C++ of step (2) with the diffuse colour ``kd``, which must be the albedo where a
    pixel is not transmissive: a chunk without a transmissive pixel takes its albedo as
    it is (``kd``'s glass terms, a Fresnel factor with three divisions, computed for
    every pixel of a branch-free loop, fold away)."""
    return f"""
    int glass_lanes = 0;
    for (int j = 0; j < n; ++j) glass_lanes += (flags[j] & {int(FLAG_TRANSMISSIVE)}) != 0 ? 1 : 0;
    auto view = [&](const bool glass) WH_INLINE {{
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 nn(nx[j], ny[j], nz[j]);
            const wp::vec3 v = wh_normalize(wp::sub(eye, wp::vec3(px[j], py[j], pz[j])));
            const wp::vec3 kd = glass ? {kd} : wp::vec3(ar[j], ag[j], ab[j]);
            vx[j] = v[0]; vy[j] = v[1]; vz[j] = v[2];
            kr[j] = kd[0]; kg[j] = kd[1]; kb[j] = kd[2];
            dr[j] = 0.0f; dg[j] = 0.0f; db[j] = 0.0f;
        }}
    }};
    if (glass_lanes > 0) view(true); else view(false);
"""


#: The deferred pass's diffuse colour (``shading.diffuse_albedo``).
RASTER_KD_CPP = "wh_diffuse_albedo(false, dome, nn, v, wp::vec3(ar[j], ag[j], ab[j]), opac[j], ior[j], flags[j])"


# (3) every light ``lights_begin`` .. ``lights_end - 1``: its term into cr, cg, cb, then
# ``accumulate`` (C++ of a loop over the lanes) adds it to dr, dg, db.
def light_loop_cpp(accumulate: str) -> str:
    """C++ of step (3), each light's term summed by ``accumulate``."""
    return (
        """
    for (int li = lights_begin; li < lights_end; ++li) {
        const auto light = scene.lights.data[li];
        const bool has_cone = wh_has_cone(light);
        const float cos_inner = has_cone ? wh_cone_inner(light) : 0.0f;
        auto lane = [&](const int kind, const int rect_path, const int j) WH_INLINE {
            const wp::vec3 p(px[j], py[j], pz[j]);
            const wp::vec3 nn(nx[j], ny[j], nz[j]);
            wp::vec3 wi, e_normal, irradiance;
            float distance;
            wh_light_sample(light, kind, has_cone, cos_inner, p, nn, true, rect_path, wi, distance, e_normal,
                            irradiance);
            const wp::vec3 c = wh_light_response(false, wi, e_normal, irradiance, nn, wp::vec3(vx[j], vy[j], vz[j]),
                                                 wp::vec3(kr[j], kg[j], kb[j]), wp::vec3(fr[j], fg[j], fb[j]), rough[j]);
            cr[j] = c[0]; cg[j] = c[1]; cb[j] = c[2];
        };
        if (light.kind == WH_DISTANT) {
            for (int j = 0; j < n; ++j) lane(WH_DISTANT, WH_RECT_ANY, j);
        } else if (light.kind == WH_SPHERE) {
            for (int j = 0; j < n; ++j) lane(WH_SPHERE, WH_RECT_ANY, j);
        } else if (light.kind == WH_RECT) {
            int above = 0;
            for (int j = 0; j < n; ++j) {
                above += wh_rect_above(wp::sub(light.position, wp::vec3(px[j], py[j], pz[j])), light.axis_u,
                                       light.axis_v, wp::vec3(nx[j], ny[j], nz[j])) ? 1 : 0;
            }
            if (above == n) {
                for (int j = 0; j < n; ++j) lane(WH_RECT, WH_RECT_ABOVE, j);
            } else if (above == 0) {
                for (int j = 0; j < n; ++j) lane(WH_RECT, WH_RECT_CLIPPED, j);
            } else {
                for (int j = 0; j < n; ++j) lane(WH_RECT, WH_RECT_ANY, j);
            }
        } else {
            for (int j = 0; j < n; ++j) lane(-1, WH_RECT_ANY, j);
        }
"""
        + accumulate
        + """
    }
"""
    )


#: The unshadowed sum: each light's term added as it is.
_UNSHADOWED_SUM_CPP = """
        for (int j = 0; j < n; ++j) {
            dr[j] += cr[j]; dg[j] += cg[j]; db[j] += cb[j];
        }"""
_LIGHTS_CPP = view_cpp(RASTER_KD_CPP) + light_loop_cpp(_UNSHADOWED_SUM_CPP)

# The dome's texel reads of (4) (below), three bilinear fetches a pixel: ``fa`` the level its
# lobe reads (level 0, the dome's own texture, on the background and without a mip chain),
# ``fb`` the next level where the lobe lies between two, ``ft`` the dome straight behind
# glass.  Each fetch's lane arrays: its four texels' element indices (``wh_latlong_footprint``),
# its weights, and its bilinear value's three channels.
_FETCHES = ("fa", "fb", "ft")
_FETCH_ARRAYS_CPP = "\n".join(
    f"int {f}00[CHUNK], {f}01[CHUNK], {f}10[CHUNK], {f}11[CHUNK];\nfloat {f}x[CHUNK], {f}y[CHUNK], {f}c[3][CHUNK];"
    for f in _FETCHES
)


def dome_terms_cpp(raster: bool) -> str:
    """C++ of (4a-c): what a textured dome gives each lane of the chunk (an untextured one
    is direction-free: ``lit_span`` takes its one value for the row instead).

    (a) across lanes, the irradiance at the normal (SH) into ``ir, ig, ib``, the dome-local
    direction the lane reads (the mirror direction on a surface; with ``raster`` the camera
    ray on the background) and its lat-long uv; then ``wh_prefiltered_at``'s choices as selects: the
    lobe's level of detail (``wh_prefilter_lod``), the level ``fa`` reads and whether it
    blends with a second value (the next level ``fb``, or past the chain's top the SH
    irradiance) and by what weights, and each fetch's footprint (every lane's, as the loop
    has no branches); (b) the loads of the fetches a lane uses and their bilinear blend,
    lane by lane (``environment.texel_gather_cpp``); (c) across lanes the looked-up radiance into ``sr, sg, sb`` (the dome's
    colour, scale and bias on level 0's values, the blend of the two values); and with
    ``raster``, in a chunk with a transmissive pixel (``glass_lanes``), the dome straight
    behind each glass pixel (what glass lets through) into ``tr, tg, tb``, its uv and
    footprint across lanes, its loads lane by lane.  ``hit[j]``: the lane reads the
    lobe at its surface's mirror direction; a lane that is not one reads level 0 along its
    camera ray with ``raster``, nothing without (its values are not used; a chunk without
    a lane that reads the lobe then takes the irradiance alone, its radiance zero).  The same
    operations as the scalar lookups (``wh_environment_radiance_at``, ``wh_prefiltered_at``),
    so the same bits."""
    if raster:
        direction = """const wp::vec3 ray = wh_pixel_ray(wp::add((float)(xs + j), cam.sample[0]), wp::add((float)y, cam.sample[1]));
        const wp::vec3 d = wp::mul(env.world_to_light, wh_select(hit[j], mirror, ray));"""
        # (only in a chunk with a transmissive pixel: ``glass_lanes``, ``view_cpp``)
        behind = f"""
    if (glass_lanes > 0) {{
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 v(vx[j], vy[j], vz[j]);
            const wp::vec2 behind = wh_environment_uv(wp::mul(env.world_to_light, wp::neg(v)));
            glass[j] = hit[j] && dome && (flags[j] & {int(FLAG_TRANSMISSIVE)}) != 0;
            wh_latlong_footprint(dome_offset, dome_width, dome_height, behind, ft00[j], ft01[j], ft10[j], ft11[j],
                                 ftx[j], fty[j]);
        }}
{texel_gather_cpp("ft", "n", "glass[j] && textured", "dome_texel_floats")}
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 b(ftc[0][j], ftc[1][j], ftc[2][j]);
            const wp::vec3 behind = textured ? wh_dome_scaled(env, *dome_texture, b) : env.color;
            const wp::vec3 tt = glass[j] ? behind : wp::vec3(0.0f);
            tr[j] = tt[0]; tg[j] = tt[1]; tb[j] = tt[2];
        }}
    }}"""
        first_wanted = "level[j] != 0 || textured"
    else:
        direction = "const wp::vec3 d = wp::mul(env.world_to_light, mirror);"
        behind = ""
        first_wanted = "hit[j] && (level[j] != 0 || textured)"
    irradiance = """
        const wp::vec3 nn(nx[j], ny[j], nz[j]);
        const wp::vec3 v(vx[j], vy[j], vz[j]);
        const wp::vec3 e = wh_ambient_irradiance(env, amb, nn, false);
        ir[j] = e[0]; ig[j] = e[1]; ib[j] = e[2];"""
    uv = f"""
        const wp::vec3 mirror = wp::sub(wp::mul(nn, wp::mul(2.0f, wp::dot(nn, v))), v);
        {direction}
        ox[j] = d[0]; oy[j] = d[1]; oz[j] = d[2];
        const wp::vec2 uv = wh_environment_uv(d);
        ux[j] = uv[0]; uy[j] = uv[1];"""
    if raster:  # (every lane reads the dome: its surface's lobe or its camera ray)
        head = f"""
    for (int j = 0; j < n; ++j) {{{irradiance}{uv}
    }}
    {{"""
    else:  # (without a lane that looks the lobe up, the irradiance alone)
        head = f"""
    for (int j = 0; j < n; ++j) {{{irradiance}
    }}
    int lookups = 0;
    for (int j = 0; j < n; ++j) lookups += hit[j] ? 1 : 0;
    if (lookups == 0) {{
        for (int j = 0; j < n; ++j) {{
            sr[j] = 0.0f; sg[j] = 0.0f; sb[j] = 0.0f;
        }}
    }} else {{
    for (int j = 0; j < n; ++j) {{
        const wp::vec3 nn(nx[j], ny[j], nz[j]);
        const wp::vec3 v(vx[j], vy[j], vz[j]);{uv}
    }}"""
    return f"""{head}
    // (the lobe's level of detail once per run of lanes with one roughness: a row's pixels
    // mostly share their material's, and its log2 is a library call the loop below would
    // make for every lane; equal roughness gives the same bits, -0 included, as the level
    // reads its square)
    float run_roughness = 0.0f, run_lod = 0.0f;
    for (int j = 0; j < n; ++j) {{
        if (j == 0 || !(rough[j] == run_roughness)) {{
            run_roughness = rough[j];
            run_lod = wh_prefilter_lod(amb, run_roughness);
        }}
        lods[j] = run_lod;
    }}
    for (int j = 0; j < n; ++j) {{
        const wp::vec2 uv(ux[j], uy[j]);
        const float lod = lods[j];
        const bool lobe = hit[j] && amb.levels > 0;
        const bool past_top = lobe && lod >= top;
        const int l0 = (int)wp::floor(wp::min(lod, top));  // (lod < top where it is read)
        const float t = past_top ? wp::min(wp::sub(lod, top), 1.0f) : wp::sub(lod, (float)l0);
        const int la = lobe ? (past_top ? amb.levels : l0) : 0;
        level[j] = la;
        above_top[j] = past_top;
        two_levels[j] = lobe && !past_top && !(t <= 0.0f);
        keep[j] = wp::sub(1.0f, t);
        add_weight[j] = past_top ? wp::mul(WH_INV_PI, t) : t;
        // (the tables read unconditionally, each index in range, so the loop has no branches)
        const int ka = wp::max(la - 1, 0);
        const int a_offset = amb.mip_offset.data[ka], a_width = amb.mip_width.data[ka];
        const int a_height = amb.mip_height.data[ka];
        wh_latlong_footprint(la == 0 ? dome_offset : a_offset, la == 0 ? dome_width : a_width,
                             la == 0 ? dome_height : a_height, uv, fa00[j], fa01[j], fa10[j], fa11[j], fax[j],
                             fay[j]);
    }}
    // (the next level's footprint and the SH irradiance past the top only in a chunk with a
    // lane that reads them)
    int second_levels = 0, past_tops = 0;
    for (int j = 0; j < n; ++j) {{
        second_levels += two_levels[j] ? 1 : 0;
        past_tops += above_top[j] ? 1 : 0;
    }}
    if (second_levels > 0) {{
        for (int j = 0; j < n; ++j) {{
            const int l0 = (int)wp::floor(wp::min(lods[j], top));
            const int kb = wp::clamp(l0, 0, wp::max(amb.levels - 1, 0));
            wh_latlong_footprint(amb.mip_offset.data[kb], amb.mip_width.data[kb], amb.mip_height.data[kb],
                                 wp::vec2(ux[j], uy[j]), fb00[j], fb01[j], fb10[j], fb11[j], fbx[j], fby[j]);
        }}
    }}
{texel_gather_cpp("fa", "n", first_wanted, "dome_texel_floats", "mip_texel_floats", "level[j] == 0")}
{texel_gather_cpp("fb", "n", "two_levels[j]", "dome_texel_floats", "mip_texel_floats", "false")}
    // (a literal ``any_top``: false where no lane reads past the top, whose SH irradiance
    // then folds away)
    auto looked_up = [&](const bool any_top) WH_INLINE {{
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 a(fac[0][j], fac[1][j], fac[2][j]);
            const wp::vec3 on_dome = textured ? wh_dome_scaled(env, *dome_texture, a) : env.color;
            const wp::vec3 first = level[j] == 0 ? wh_select(dome, on_dome, wp::vec3(0.0f)) : a;
            const bool top_lane = any_top && above_top[j];
            const wp::vec3 second = top_lane ? wh_sh_irradiance(amb, wh_normalize(wp::vec3(ox[j], oy[j], oz[j])), false)
                                             : wp::vec3(fbc[0][j], fbc[1][j], fbc[2][j]);
            // (the sum's terms in this order, rounded as the deferred module's FMA contraction
            // rounds the scalar ``wh_prefiltered_at``: the same bits)
            const float w = add_weight[j], k = keep[j];
            const wp::vec3 blend(wh_add_products(second[0], w, first[0], k), wh_add_products(second[1], w, first[1], k),
                                 wh_add_products(second[2], w, first[2], k));
            const wp::vec3 s = top_lane || two_levels[j] ? blend : first;
            sr[j] = s[0]; sg[j] = s[1]; sb[j] = s[2];
        }}
    }};
    if (past_tops > 0) looked_up(true); else looked_up(false);
    }}{behind}
"""


#: The lane arrays of ``dome_terms_cpp`` and the dome's record (given ``scene``, ``amb`` and
#: ``dome``, whether the scene has one); under a direction-free dome (``uniform_dome``)
#: its one irradiance ``e_free`` and one radiance ``sky``, the values ``dome_terms_cpp``
#: would give every lane.
DOME_LANES_CPP = (
    """
const auto& env = scene.environment;
const bool uniform_dome = wh_direction_free(env, amb);
const wp::vec3 up(0.0f, 0.0f, 1.0f);  // (any direction)
const wp::vec3 e_free = uniform_dome ? wh_ambient_irradiance(env, amb, up, true) : wp::vec3(0.0f);
const wp::vec3 sky = uniform_dome ? wh_environment_radiance(env, scene.textures, scene.texels, up) : wp::vec3(0.0f);
float ir[CHUNK], ig[CHUNK], ib[CHUNK], sr[CHUNK], sg[CHUNK], sb[CHUNK];
float tr[CHUNK], tg[CHUNK], tb[CHUNK], ox[CHUNK], oy[CHUNK], oz[CHUNK], ux[CHUNK], uy[CHUNK];
bool hit[CHUNK], above_top[CHUNK], two_levels[CHUNK], glass[CHUNK];
int level[CHUNK];
float keep[CHUNK], add_weight[CHUNK], lods[CHUNK];
"""
    + _FETCH_ARRAYS_CPP
    + """
const bool textured = dome && env.texture >= 0;
const auto* dome_texture = textured ? &scene.textures.data[env.texture] : nullptr;
const int dome_offset = textured ? dome_texture->offset : 0;
const int dome_width = textured ? dome_texture->width : 1;
const int dome_height = textured ? dome_texture->height : 1;
const float top = (float)amb.levels;
const float* dome_texel_floats = (const float*)scene.texels.data;
const float* mip_texel_floats = (const float*)amb.mip_texels.data;
"""
)

# What ``lit_span`` meters with ``meter`` (the CPU's row loop, a launch item a whole row):
# the post stage's log-luminance sum of the row (``post.kernels``: each hit pixel's Rec. 709
# luminance, where finite, its ``log(delta + max(Y, 0))`` added in order in float64, and
# how many), from the radiance the chunk writes, so the pass that reads the layer next
# need not.  The luminance is the post module's expression (``exposure.LOG_LUMINANCE_CPP``)
# without FMA contraction, as Warp's default build compiles that module, not under this
# module's ``-ffp-contract=fast``, and its log term (``wh_log_float``) rounds each operation
# as written in any module, so the sums are its bits.  The terms across the chunk (a loop
# the compiler vectorises), then the counted ones added in order.
_METER_CHUNK_CPP = f"""
#if !defined(__CUDA_ARCH__)
    if (meter != 0) {{
        double terms[CHUNK];
        bool counts[CHUNK];
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 c(cr[j], cg[j], cb[j]);
            // (the luminance without FMA contraction, as the post module computes it)
            const float l = [&]() -> float {{
#pragma clang fp contract(off)
                {LOG_LUMINANCE_CPP}
                return l;
            }}();
            counts[j] = hit[j] && {LOG_COUNTS_CPP};
            terms[j] = {LOG_TERM_CPP};
        }}
        for (int j = 0; j < n; ++j) {{
            if (counts[j]) {{
                meter_total = wp::add(meter_total, terms[j]);
                ++meter_n;
            }}
        }}
    }}
#endif
"""

# (4) of ``lit_span``: what the dome gives each pixel of the chunk, then its radiance.
# Under a direction-free dome (``ambient.direction_free``) one irradiance ``e_free`` and
# one radiance ``sky`` for every pixel; otherwise ``dome_terms_cpp``'s.  Then (d) across
# pixels ``shading.shade_surface`` given those (``wh_surface_radiance`` with the split-sum
# ``wh_env_brdf`` times the looked-up radiance), the dome's radiance where the pixel sees
# no surface.
_RADIANCE_CPP = f"""
    if (!uniform_dome) {{{dome_terms_cpp(raster=True)}    }}
    // (a literal ``uniform``: the row's one irradiance and radiance, folded in as constants;
    // a literal ``glass``: false in a chunk without a transmissive pixel, whose light
    // through glass then folds away)
    // (a literal ``ambient`` false where the dome's ambient terms are off: the split-sum
    // lookup, whose result the select below would drop, folds away; where they are on the
    // select stays one the compiler cannot fold, ``ambient_on`` hidden from it, so the
    // product it selects is rounded as it always was rather than fused into the sum)
    bool ambient_on = amb.enabled != 0;
#if !defined(__CUDA_ARCH__)
    __asm__("" : "+r"(ambient_on));
#endif
    auto radiance = [&](const bool uniform, const bool glass, const bool ambient) WH_INLINE {{
        for (int j = 0; j < n; ++j) {{
            const wp::vec3 nn(nx[j], ny[j], nz[j]);
            const wp::vec3 v(vx[j], vy[j], vz[j]);
            const wp::vec3 f0(fr[j], fg[j], fb[j]);
            const wp::vec3 s = uniform ? sky : wp::vec3(sr[j], sg[j], sb[j]);
            const wp::vec3 e = uniform ? e_free : wp::vec3(ir[j], ig[j], ib[j]);
            const wp::vec3 t = uniform ? sky : wp::vec3(tr[j], tg[j], tb[j]);
            const wp::vec3 glossy = ambient ? wh_select(ambient_on,
                                                        wp::cw_mul(wh_env_brdf(amb.brdf_lut, f0, rough[j],
                                                                               wp::dot(nn, v)), s),
                                                        wp::vec3(0.0f))
                                            : wp::vec3(0.0f);
            const wp::vec3 c = wh_surface_radiance(false, glass && dome, nn, v, wp::vec3(ar[j], ag[j], ab[j]),
                                                   wp::vec3(kr[j], kg[j], kb[j]), f0, wp::vec3(er[j], eg[j], eb[j]),
                                                   opac[j], ior[j], flags[j], wp::vec3(dr[j], dg[j], db[j]), e, glossy,
                                                   t);
            cr[j] = hit[j] ? c[0] : s[0]; cg[j] = hit[j] ? c[1] : s[1]; cb[j] = hit[j] ? c[2] : s[2];
        }}
    }};
    if (glass_lanes > 0) {{
        if (!uniform_dome) radiance(false, true, true);
        else if (amb.enabled != 0) radiance(true, true, true);
        else radiance(true, true, false);
    }} else {{
        if (!uniform_dome) radiance(false, false, true);
        else if (amb.enabled != 0) radiance(true, false, true);
        else radiance(true, false, false);
    }}
    wh_write_floats((float*)(out + xs), 3, n, cr, cg, cb, nullptr);
{_METER_CHUNK_CPP}"""

# A chunk of background pixels alone (most of a row that sees the sky) takes only the
# dome along each camera ray (``environment.dome_along_lanes_cpp``, which the path kernel's
# background uses too): the values ``dome_terms_cpp`` and ``_RADIANCE_CPP`` give a lane that
# sees no surface (its lobe level 0, the dome's own texture), without the G-buffer's reads,
# the lights, the irradiance and the second level's footprint.
_BACKGROUND_DOME_CPP = dome_along_lanes_cpp(
    "CHUNK",
    "n",
    "wh_pixel_ray(wp::add((float)(xs + j), cam.sample[0]), wp::add((float)y, cam.sample[1]))",
    "true",
    "const wp::vec3 sky_c = wh_select(dome, c, wp::vec3(0.0f)); cr[j] = sky_c[0]; cg[j] = sky_c[1]; cb[j] = sky_c[2];",
)
_BACKGROUND_CHUNK_CPP = f"""
    int surface_lanes = 0;
    for (int j = 0; j < n; ++j) surface_lanes += triangle[xs + j] >= 0 ? 1 : 0;
    if (surface_lanes == 0) {{
        if (uniform_dome || !textured) {{
            const wp::vec3 c = uniform_dome ? sky : wh_select(dome, env.color, wp::vec3(0.0f));
            for (int j = 0; j < n; ++j) {{
                cr[j] = c[0]; cg[j] = c[1]; cb[j] = c[2];
            }}
        }} else {{{_BACKGROUND_DOME_CPP}
        }}
        wh_write_floats((float*)(out + xs), 3, n, cr, cg, cb, nullptr);
        continue;
    }}"""

# The camera ray through image point (px, py), as ``camera.camera_ray`` (defined before
# the loop's lane arrays, whose names it would hide).
_PIXEL_RAY_CPP = f"""
auto wh_pixel_ray = [&](const float px, const float py) WH_INLINE -> wp::vec3 {{
{CAMERA_RAY_CPP}
    return ray;
}};
"""


# The row's metered sum and count (with ``meter``), stored as the post stage's sums leave
# them: zero where no pixel counts, else 0 + the sum (its atomic add into a zeroed row).
_METER_ROW_CPP = """
#if !defined(__CUDA_ARCH__)
if (meter != 0) {
    meter_sum.data[y] = meter_n > 0 ? wp::add(0.0, meter_total) : 0.0;
    meter_count.data[y] = meter_n;
}
#endif
"""


def _span_cpp(lit: bool) -> str:
    """The C++ of ``direct_span`` (``lit`` false: the lights' sum into ``target``) or of
    ``lit_span`` (true: the emission and the hit record gathered too, the radiance into
    ``target``)."""
    lit_gather = (
        """
        const wp::vec3 em = emissive != 0 ? emission[x] : wp::vec3(0.0f);
        er[j] = em[0]; eg[j] = em[1]; eb[j] = em[2];
        hit[j] = triangle[x] >= 0;"""
        if lit
        else ""
    )
    lit_rows = (
        f"""
const wp::vec3* emission = {row_cpp("gb.emission", "y", "wp::vec3")};
const int* triangle = {row_cpp("gb.triangle_id", "y", "int")};
float er[CHUNK], eg[CHUNK], eb[CHUNK];"""
        + DOME_LANES_CPP
        if lit
        else ""
    )
    if lit:
        shade = f"""{view_cpp(RASTER_KD_CPP)}{light_loop_cpp(_UNSHADOWED_SUM_CPP)}{_RADIANCE_CPP}"""
    else:
        shade = _LIGHTS_CPP + "    for (int j = 0; j < n; ++j) out[xs + j] = wp::vec3(dr[j], dg[j], db[j]);\n"
    return (
        CHUNK_CPP
        + cpp(
            "light_sample",
            "light_response",
            "diffuse_albedo",
            *(("env_brdf", "surface_radiance", "ambient_irradiance", "prefiltered_radiance") if lit else ()),
        )
        + (_PIXEL_RAY_CPP + STREAM_CPP + LOG_FLOAT_CPP if lit else "")
        + f"""
const wp::vec3* position = {row_cpp("gb.position", "y", "wp::vec3")};
const wp::vec3* normal = {row_cpp("gb.normal", "y", "wp::vec3")};
const wp::vec3* albedo = {row_cpp("gb.albedo", "y", "wp::vec3")};
const wp::vec3* specular = {row_cpp("gb.specular", "y", "wp::vec3")};
const int* material = {row_cpp("gb.material_id", "y", "int")};
const auto optics = (decltype(gb.optics.data))((char*)gb.optics.data + (size_t)y * gb.optics.strides[0]);
wp::vec3* out = {row_cpp("target", "y", "wp::vec3", const=False)};
const bool dome = scene.environment.enabled != 0;
const wp::vec3 eye = cam.origin;
{"double meter_total = 0.0;" if lit else ""}
{"int meter_n = 0;" if lit else ""}
{LANE_ARRAYS_CPP}{lit_rows}
for (int xs = x0; xs < x1; xs += CHUNK) {{
    const int n = x1 - xs < CHUNK ? x1 - xs : CHUNK;{_BACKGROUND_CHUNK_CPP if lit else ""}
    for (int j = 0; j < n; ++j) {{
        const int x = xs + j;
{lane_fill_cpp("position[x]", "normal[x]", "albedo[x]", "specular[x]", "optics[x]", "material[x]")}{lit_gather}
    }}
{shade}}}
{"WH_STREAM_FENCE();" if lit else ""}
{_METER_ROW_CPP if lit else ""}
"""
    )


@wp.func_native(_span_cpp(lit=False))
def direct_span(
    scene: SceneGPU,
    cam: CameraGPU,
    gb: GBufferArrays,
    target: wp.array2d(dtype=wp.vec3),
    lights_begin: int,
    lights_end: int,
    y: int,
    x0: int,
    x1: int,
):
    """Into ``target[y, x]`` for ``x0 <= x < x1``: the sum over the scene's lights
    ``lights_begin <= i < lights_end`` of each one's unshadowed response at the pixel's
    G-buffer point (``shading.direct_light`` with ``shading.diffuse_albedo``'s colour),
    pixel by pixel the same arithmetic (one light: its term alone)."""
    ...


@wp.func_native(_span_cpp(lit=True))
def lit_span(
    scene: SceneGPU,
    amb: AmbientGPU,
    cam: CameraGPU,
    gb: GBufferArrays,
    target: wp.array2d(dtype=wp.vec3),
    lights_begin: int,
    lights_end: int,
    emissive: int,
    meter: int,
    meter_sum: wp.array(dtype=wp.float64),
    meter_count: wp.array(dtype=wp.int32),
    y: int,
    x0: int,
    x1: int,
):
    """Into ``target[y, x]`` for ``x0 <= x < x1``: the pixel's radiance,
    ``shading.shade_surface`` over the unshadowed sum of lights ``lights_begin`` ..
    ``lights_end - 1`` (as ``direct_span``) with the dome's ambient terms, the dome's
    radiance along the camera ray (``environment_radiance``; black without a dome) where
    the pixel sees no surface; pixel by pixel the same arithmetic.  ``emissive`` 0: the
    scene has no emissive material (``SceneFeatures.emission``), so the emission channel,
    zero, is not read."""
    ...
