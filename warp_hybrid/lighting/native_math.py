"""The BRDF's, the lights' and the shading sum's arithmetic, written once as C++ (lambdas), for
two kinds of caller.

* The scalar ``@wp.func_native`` functions of ``brdf.py``, ``lights.py``, ``ambient.py``
  and ``shading.py`` (what the tracer, the shadow passes and the tests call) each hold
  ``cpp(name)``: the lambdas the function needs, then one call.
* The deferred pass's row loops (``direct_rows.py``) evaluate the same lambdas over a
  chunk of pixels at a time, one light at a time, as plain arithmetic the compiler
  vectorises across pixels (a light's kind and cone are the same for every pixel of the
  loop, so they are decided outside it), and the dome's ambient terms and the sum too.

The dome's own lookups (the lat-long uv, the bilinear fetch, its radiance) are
``scene/device/environment.py``'s lambdas, pasted here as the piece "environment".

The Python docstrings of the functions (``brdf.py``, ``lights.py``, ``ambient.py``,
``shading.py``) state the model; the text here is its only implementation.  Where a
result is a choice, the lambdas compute both sides and select (branches would stop the
row loop's vectorisation); a ``scalar`` argument (true in the scalar functions) lets the
costly ones skip, for one point, the side that is not chosen.  Every piece names the
pieces it calls (``Piece.needs``), and ``cpp`` emits a piece after everything it needs,
once.  Names start with ``wh_`` (the snippets they are pasted into have arguments of
their own). On the CPU the lambdas are forced inline (``WH_INLINE``): a light's kind
passed as a literal then folds away and the row loop's body is straight-line code.
"""

from __future__ import annotations

from dataclasses import dataclass

import warp as wp

from ..core.constants import ALPHA_MIN, INV_PI, LUMA_709_CPP, PI, TWO_PI
from ..core.native_rows import LAMBDA_HEADER_CPP, float_literal
from ..core.scene_gpu import FLAG_TRANSMISSIVE
from ..scene.device.environment import ENVIRONMENT_LAMBDAS_CPP, SH_C0, SH_C1, SH_C2, SH_C20, SH_C22
from ..scene.model import LightKind

#: The smallest n.v the specular lobe and the glass terms divide by.
COS_EPS = wp.constant(1.0e-4)


@dataclass(frozen=True)
class Piece:
    """One lambda: its C++ text (defining ``wh_<name>``) and the pieces it calls."""

    text: str
    needs: tuple[str, ...] = ()


#: The C++ that every snippet starts with: the lambdas' header and the constants.
_HEADER = (
    LAMBDA_HEADER_CPP
    + f"""
constexpr float WH_PI = {float_literal(PI)};
constexpr float WH_INV_PI = {float_literal(INV_PI)};
constexpr float WH_ALPHA_MIN = {float_literal(ALPHA_MIN)};
constexpr float WH_COS_EPS = {float_literal(COS_EPS)};
constexpr int WH_DISTANT = {int(LightKind.DISTANT)};
constexpr int WH_SPHERE = {int(LightKind.SPHERE)};
constexpr int WH_RECT = {int(LightKind.RECT)};
constexpr int WH_RECT_ANY = 0;
constexpr int WH_RECT_ABOVE = 1;
constexpr int WH_RECT_CLIPPED = 2;
constexpr int WH_RECT_ONE = 3;
"""
)

PIECES: dict[str, Piece] = {
    # ---- the BRDF (brdf.py) ----
    "luma709": Piece(f"""auto wh_luma709 = [&](const wp::vec3& c) WH_INLINE -> float {{ return {LUMA_709_CPP}; }};"""),
    "roughness_to_alpha": Piece(
        """auto wh_roughness_to_alpha = [&](float roughness) WH_INLINE -> float {
    const float r = wp::clamp(roughness, 0.0f, 1.0f);
    return wp::max(r * r, WH_ALPHA_MIN);
};"""
    ),
    "fresnel_f90": Piece(
        """auto wh_fresnel_f90 = [&](const wp::vec3& f0) WH_INLINE -> float {
    return wp::clamp(50.0f * wh_luma709(f0), 0.0f, 1.0f);
};""",
        ("luma709",),
    ),
    "fresnel_schlick": Piece(
        """auto wh_fresnel_schlick = [&](const wp::vec3& f0, float cos_theta) WH_INLINE -> wp::vec3 {
    const float c = wp::clamp(1.0f - cos_theta, 0.0f, 1.0f);
    const float c2 = c * c;
    const float w = c2 * c2 * c;
    const float f90 = wh_fresnel_f90(f0);
    return wp::add(f0, wp::mul(wp::sub(wp::vec3(f90, f90, f90), f0), w));
};""",
        ("fresnel_f90",),
    ),
    "fresnel_dielectric": Piece(
        """auto wh_fresnel_dielectric = [&](float cos_i, float eta) WH_INLINE -> float {
    const float c = wp::min(wp::abs(cos_i), 1.0f);
    const float sin_t2 = (1.0f - c * c) / (eta * eta);
    const float cos_t = wp::sqrt(wp::max(1.0f - sin_t2, 0.0f));
    const float rs = (c - eta * cos_t) / (c + eta * cos_t);
    const float rp = (eta * c - cos_t) / (eta * c + cos_t);
    return sin_t2 >= 1.0f ? 1.0f : 0.5f * (rs * rs + rp * rp);
};"""
    ),
    "ggx_d": Piece(
        """auto wh_ggx_d = [&](float n_dot_h, float alpha) WH_INLINE -> float {
    const float a2 = alpha * alpha;
    const float d = n_dot_h * n_dot_h * (a2 - 1.0f) + 1.0f;
    return a2 / (WH_PI * d * d);
};"""
    ),
    "smith_visibility": Piece(
        """auto wh_smith_visibility = [&](float n_dot_v, float n_dot_l, float alpha) WH_INLINE -> float {
    const float a2 = alpha * alpha;
    const float gv = n_dot_l * wp::sqrt(n_dot_v * n_dot_v * (1.0f - a2) + a2);
    const float gl = n_dot_v * wp::sqrt(n_dot_l * n_dot_l * (1.0f - a2) + a2);
    return 0.5f / wp::max(gv + gl, 1.0e-12f);
};"""
    ),
    "half_vector": Piece(
        """auto wh_half_vector = [&](const wp::vec3& v, const wp::vec3& l) WH_INLINE -> wp::vec3 {
    const wp::vec3 h = wp::add(v, l);
    const float len_h = wp::length(h);
    return wh_select(len_h < 1.0e-8f, v, wp::div(h, len_h));
};"""
    ),
    "diffuse_view_weight": Piece(
        """auto wh_diffuse_view_weight = [&](const wp::vec3& f0, float n_dot_v) WH_INLINE -> wp::vec3 {
    return wp::sub(wp::vec3(1.0f, 1.0f, 1.0f), wh_fresnel_schlick(f0, n_dot_v));
};""",
        ("fresnel_schlick",),
    ),
    "brdf_diffuse": Piece(
        """auto wh_brdf_diffuse = [&](const wp::vec3& n, const wp::vec3& v, const wp::vec3& l, const wp::vec3& albedo,
                         const wp::vec3& f0) WH_INLINE -> wp::vec3 {
    const wp::vec3 one(1.0f, 1.0f, 1.0f);
    const float f90 = wh_fresnel_f90(f0);
    const wp::vec3 f_avg = wp::add(f0, wp::mul(wp::sub(wp::vec3(f90, f90, f90), f0), 1.0f / 21.0f));
    const wp::vec3 w_l = wp::sub(one, wh_fresnel_schlick(f0, wp::clamp(wp::dot(n, l), 0.0f, 1.0f)));
    const wp::vec3 w_v = wh_diffuse_view_weight(f0, wp::clamp(wp::dot(n, v), 0.0f, 1.0f));
    const wp::vec3 k = wp::sub(one, f_avg);
    const wp::vec3 keep(wp::max(k[0], 1.0e-6f), wp::max(k[1], 1.0e-6f), wp::max(k[2], 1.0e-6f));
    const wp::vec3 w = wp::cw_div(wp::cw_mul(w_l, w_v), keep);
    return wp::cw_mul(wp::mul(albedo, WH_INV_PI), w);
};""",
        ("fresnel_f90", "fresnel_schlick", "diffuse_view_weight"),
    ),
    "brdf_specular": Piece(
        """auto wh_brdf_specular = [&](const wp::vec3& n, const wp::vec3& v, const wp::vec3& l, const wp::vec3& f0,
                          float roughness) WH_INLINE -> wp::vec3 {
    const float n_dot_l = wp::dot(n, l);
    const float n_dot_v = wp::max(wp::dot(n, v), WH_COS_EPS);
    const wp::vec3 h = wh_half_vector(v, l);
    const float alpha = wh_roughness_to_alpha(roughness);
    const float d = wh_ggx_d(wp::max(wp::dot(n, h), 0.0f), alpha);
    const float vis = wh_smith_visibility(n_dot_v, n_dot_l, alpha);
    const wp::vec3 s = wp::mul(wh_fresnel_schlick(f0, wp::dot(v, h)), d * vis);
    return wh_select(n_dot_l <= 0.0f, wp::vec3(0.0f), s);
};""",
        ("half_vector", "roughness_to_alpha", "ggx_d", "smith_visibility", "fresnel_schlick"),
    ),
    # ---- the lights (lights.py) ----
    "subtended_angle": Piece(
        """auto wh_subtended_angle = [&](float s, float c) WH_INLINE -> float {
    const float ac = wp::abs(c);
    const bool steep = s > ac;
    const float hi = steep ? s : ac;
    const float t = (steep ? ac : s) / hi;
    const float t2 = t * t;
    float p = -0.013480470f;
    p = p * t2 + 0.057477314f;
    p = p * t2 - 0.121239071f;
    p = p * t2 + 0.195635925f;
    p = p * t2 - 0.332994597f;
    p = p * t2 + 0.999995630f;
    float r = p * t;
    r = steep ? 1.570796327f - r : r;
    r = c < 0.0f ? 3.141592654f - r : r;
    return hi > 0.0f ? r : 0.0f;
};"""
    ),
    "edge_term": Piece(
        """auto wh_rect_edge = [&](const wp::vec3& c, float a_dot_b, const wp::vec3& n) WH_INLINE -> float {
    const float lc = wp::sqrt(wp::dot(c, c));
    return lc > 0.0f ? wh_subtended_angle(lc, a_dot_b) * wp::dot(c, n) / lc : 0.0f;
};
auto wh_edge_term = [&](const wp::vec3& a, const wp::vec3& b, const wp::vec3& n) WH_INLINE -> float {
    return wh_rect_edge(wp::cross(a, b), wp::dot(a, b), n);
};""",
        ("subtended_angle",),
    ),
    # Branch-free (each edge's term computed and added or not) unless ``scalar``: the row
    # loop evaluates it across pixels; adding a zero leaves the sum's bits as a skipped
    # edge does.
    "quad_edge_sum": Piece(
        """auto wh_quad_edge_sum = [&](const wp::vec3& q0, const wp::vec3& q1, const wp::vec3& q2, const wp::vec3& q3,
                          const wp::vec3& n, const bool scalar) WH_INLINE -> float {
    float total = 0.0f;
    wp::vec3 exit_pt(0.0f), entry_pt(0.0f);
    int inside = 0;
    // The edges in order, written out (a loop left in would stop the row loop's vectorising).
    auto edge = [&](const wp::vec3& a, const wp::vec3& b) WH_INLINE {
        const float ha = wp::dot(n, a);
        const float hb = wp::dot(n, b);
        const bool in_a = ha > 0.0f;
        const bool in_b = hb > 0.0f;
        if (scalar && !in_a && !in_b) return;
        const wp::vec3 h = wp::add(a, wp::mul(wp::sub(b, a), ha / (ha - hb)));
        const float term = wh_edge_term(wh_select(in_a, a, h), wh_select(in_b, b, h), n);
        total += in_a || in_b ? term : 0.0f;
        inside += in_a ? 1 : 0;
        exit_pt = wh_select(in_a && !in_b, h, exit_pt);
        entry_pt = wh_select(!in_a && in_b, h, entry_pt);
    };
    edge(q0, q1);
    edge(q1, q2);
    edge(q2, q3);
    edge(q3, q0);
    const float closing = wh_edge_term(exit_pt, entry_pt, n);
    total += inside > 0 && inside < 4 ? closing : 0.0f;
    return inside == 0 ? 0.0f : total;
};""",
        ("edge_term",),
    ),
    # ``path``: ``WH_RECT_ABOVE`` where the caller knows the rectangle lies wholly above
    # the point's horizon (``wh_rect_above``), ``WH_RECT_CLIPPED`` where it knows it
    # does not, ``WH_RECT_ANY`` to decide per point, ``WH_RECT_ONE`` to decide for one
    # point at a time (branches: the clipped polygon skips the edges below the horizon).
    "rect_edge_sum": Piece(
        """auto wh_rect_above = [&](const wp::vec3& d, const wp::vec3& u, const wp::vec3& v, const wp::vec3& n) WH_INLINE
    -> bool {
    const float dn = wp::dot(d, n);
    const float un = wp::dot(u, n);
    const float vn = wp::dot(v, n);
    return dn - un - vn > 0.0f && dn + un - vn > 0.0f && dn + un + vn > 0.0f && dn - un + vn > 0.0f;
};
auto wh_rect_edge_sum_above = [&](const wp::vec3& d, const wp::vec3& u, const wp::vec3& v, const wp::vec3& n)
    WH_INLINE -> float {
    const wp::vec3 z = wp::cross(u, v);
    const wp::vec3 xu = wp::cross(d, u);
    const wp::vec3 xv = wp::cross(d, v);
    const float half_dd = 0.5f * wp::dot(d, d);
    const float half_k = 0.5f * (wp::dot(v, v) - wp::dot(u, u));
    const float du = wp::dot(d, u);
    const float dv = wp::dot(d, v);
    float total = wh_rect_edge(wp::add(z, xu), half_dd - dv + half_k, n);
    total += wh_rect_edge(wp::add(z, xv), half_dd + du - half_k, n);
    total += wh_rect_edge(wp::sub(z, xu), half_dd + dv + half_k, n);
    total += wh_rect_edge(wp::sub(z, xv), half_dd - du - half_k, n);
    return total;
};
auto wh_rect_edge_sum_clipped = [&](const wp::vec3& d, const wp::vec3& u, const wp::vec3& v, const wp::vec3& n,
                                    const bool scalar) WH_INLINE -> float {
    return wh_quad_edge_sum(wp::sub(wp::sub(d, u), v), wp::sub(wp::add(d, u), v), wp::add(wp::add(d, u), v),
                            wp::add(wp::sub(d, u), v), n, scalar);
};
auto wh_rect_edge_sum = [&](const wp::vec3& d, const wp::vec3& u, const wp::vec3& v, const wp::vec3& n,
                            const int path) WH_INLINE -> float {
    if (path == WH_RECT_ABOVE) return wh_rect_edge_sum_above(d, u, v, n);
    if (path == WH_RECT_CLIPPED) return wh_rect_edge_sum_clipped(d, u, v, n, false);
    const bool scalar = path == WH_RECT_ONE;
    if (wh_rect_above(d, u, v, n)) return wh_rect_edge_sum_above(d, u, v, n);
    return wh_rect_edge_sum_clipped(d, u, v, n, scalar);
};""",
        ("edge_term", "quad_edge_sum"),
    ),
    "rect_irradiance_factor": Piece(
        """auto wh_rect_irradiance_factor = [&](const wp::vec3& p, const wp::vec3& n, const auto& light, const int path)
    WH_INLINE -> float {
    const wp::vec3 d = wp::sub(light.position, p);
    if (wp::dot(d, light.direction) >= 0.0f) return 0.0f;
    const wp::vec3& u = light.axis_u;
    const wp::vec3& v = light.axis_v;
    float s = wh_rect_edge_sum(d, u, v, n, path);
    s = wp::dot(wp::cross(u, v), light.direction) > 0.0f ? -s : s;
    return wp::clamp(0.5f * s, 0.0f, WH_PI);
};""",
        ("rect_edge_sum",),
    ),
    # The ShapingAPI cone: ``wh_cone_inner`` is the light's own part (the cosine of the
    # inner angle, its acos and cos), ``wh_cone_factor`` the point's, given it.
    "cone": Piece(
        """auto wh_has_cone = [&](const auto& light) WH_INLINE -> bool { return !(light.cos_cone <= -1.0f + 1.0e-6f); };
auto wh_cone_inner = [&](const auto& light) -> float {
    const float outer = wp::acos(wp::clamp(light.cos_cone, -1.0f, 1.0f));
    return wp::cos(outer * (1.0f - wp::clamp(light.cone_softness, 0.0f, 1.0f)));
};
auto wh_cone_factor = [&](const auto& light, const bool has_cone, const float cos_inner, const wp::vec3& wi)
    WH_INLINE -> float {
    const float cos_theta = -wp::dot(light.direction, wi);
    const float t = (cos_theta - light.cos_cone) / (cos_inner - light.cos_cone);
    const float smooth = cos_theta >= cos_inner ? 1.0f : (cos_theta <= light.cos_cone ? 0.0f : t * t * (3.0f - 2.0f * t));
    return has_cone ? smooth : 1.0f;
};"""
    ),
    "centre_reaches": Piece(
        """auto wh_centre_reaches = [&](const wp::vec3& e_normal, float n_dot_l) WH_INLINE -> bool {
    return n_dot_l > 0.0f && wp::max(e_normal[0], wp::max(e_normal[1], e_normal[2])) > 0.0f;
};"""
    ),
    # Whether a light contributes at all at a point with normal n (lights.py
    # ``light_reaches``): some irradiance on the surface, or its centre above the horizon.
    "light_reaches": Piece(
        """auto wh_light_reaches = [&](const wp::vec3& irradiance, const wp::vec3& e_normal, const wp::vec3& n,
                            const wp::vec3& wi) WH_INLINE -> bool {
    return wp::max(irradiance[0], wp::max(irradiance[1], irradiance[2])) > 0.0f ||
           wh_centre_reaches(e_normal, wp::dot(n, wi));
};""",
        ("centre_reaches",),
    ),
    # What a light delivers at p (lights.py ``light_sample``): ``kind`` is the light's
    # kind (a literal in the row loop, where it folds away); ``exact``: a rect light's
    # exact irradiance everywhere, else only where the centre terms leave
    # ``light_reaches`` undecided (``reach_sample``); ``rect_path`` as ``wh_rect_edge_sum``'s.
    "light_sample": Piece(
        """auto wh_light_sample = [&](const auto& light, const int kind, const bool has_cone, const float cos_inner,
                         const wp::vec3& p, const wp::vec3& n, const bool exact, const int rect_path,
                         wp::vec3& wi, float& distance, wp::vec3& e_normal, wp::vec3& irradiance) WH_INLINE {
    if (kind == WH_DISTANT) {
        wi = wp::neg(light.direction);
        distance = INFINITY;
        e_normal = light.color;
        irradiance = wp::mul(light.color, wp::max(wp::dot(n, wi), 0.0f));
        return;
    }
    const wp::vec3 to_light = wp::sub(light.position, p);
    const float d2 = wp::dot(to_light, to_light);
    const float d = wp::sqrt(d2);
    wi = wh_select(d > 0.0f, wp::div(to_light, d), wp::vec3(0.0f, 0.0f, 1.0f));
    distance = d;
    const float cos_n = wp::max(wp::dot(n, wi), 0.0f);
    const float cone = wh_cone_factor(light, has_cone, cos_inner, wi);
    if (kind == WH_SPHERE) {
        const float r2 = light.radius * light.radius;
        const float scale = light.normalize != 0 ? 0.25f : WH_PI * r2;
        const wp::vec3 e = wh_select(r2 > 0.0f, wp::mul(light.color, scale / wp::max(d2, r2)),
                                     wp::mul(light.color, 1.0f / wp::max(d2, 1.0e-20f)));
        e_normal = wp::mul(e, cone);
        irradiance = wp::mul(e_normal, cos_n);
        return;
    }
    const float span = wp::length(wp::cross(light.axis_u, light.axis_v));
    const float disk = WH_PI * span;
    const float area = kind == WH_RECT ? 4.0f * span : (disk <= 0.0f ? WH_PI * light.radius * light.radius : disk);
    const wp::vec3 radiance = wh_select(light.normalize != 0 && area > 0.0f, wp::div(light.color, area), light.color);
    const float cos_e = wp::max(-wp::dot(light.direction, wi), 0.0f);
    const float point_factor = wp::min(area * cos_e / wp::max(d2, 1.0e-20f), WH_PI);
    e_normal = wp::mul(radiance, point_factor * cone);
    irradiance = wp::mul(e_normal, cos_n);
    if (kind == WH_RECT && (exact || !wh_centre_reaches(e_normal, cos_n))) {
        irradiance = wp::mul(radiance, wh_rect_irradiance_factor(p, n, light, rect_path) * cone);
    }
};""",
        ("cone", "centre_reaches", "rect_irradiance_factor"),
    ),
    # The diffuse colour lights and the dome see (shading.py ``diffuse_albedo``);
    # ``dome``: the scene has a dome.
    "diffuse_albedo": Piece(
        f"""auto wh_diffuse_albedo = [&](const bool scalar, const bool dome, const wp::vec3& n, const wp::vec3& v,
                           const wp::vec3& albedo, float opacity, float ior, int flags) WH_INLINE -> wp::vec3 {{
    if (scalar && (flags & {int(FLAG_TRANSMISSIVE)}) == 0) return albedo;
    const float o = wp::clamp(opacity, 0.0f, 1.0f);
    const float f = wh_fresnel_dielectric(wp::max(wp::dot(n, v), WH_COS_EPS), ior);
    const wp::vec3 glass = wh_select(dome, wp::mul(albedo, o), wp::mul(albedo, o + (1.0f - o) * (1.0f - f)));
    return wh_select((flags & {int(FLAG_TRANSMISSIVE)}) == 0, albedo, glass);
}};""",
        ("fresnel_dielectric",),
    ),
    # ---- the ambient terms and the sum (ambient.py, shading.py) ----
    # The split-sum reflectance f0 A + f90 B, (A, B) bilinear in the (roughness, n.v)
    # table ``lut`` (ambient.py ``env_brdf``).
    "env_brdf": Piece(
        """auto wh_env_brdf = [&](const wp::array_t<wp::vec2>& lut, const wp::vec3& f0, float roughness,
                     float n_dot_v) WH_INLINE -> wp::vec3 {
    const int size = lut.shape[0];
    const float fr = wp::mul(wp::clamp(roughness, 0.0f, 1.0f), (float)(size - 1));
    const float fv = wp::clamp(wp::sub(wp::mul(wp::clamp(n_dot_v, 0.0f, 1.0f), (float)size), 0.5f), 0.0f,
                               (float)(size - 1));
    const int r0 = wp::min((int)fr, size - 2);
    const int v0 = wp::min((int)fv, size - 2);
    const float tr = wp::sub(fr, (float)r0);
    const float tv = wp::sub(fv, (float)v0);
    // each of the four entries' two floats (A, B) by one ``wh_load2`` (by an int index: a
    // byte offset in size_t took two gathers of 8), then the bilinear blend of channel c
    const float* lut_floats = (const float*)lut.data;
    const int row_floats = lut.strides[0] / (int)sizeof(float), entry_floats = lut.strides[1] / (int)sizeof(float);
    float e00[2], e01[2], e10[2], e11[2];
    wh_load2(lut_floats + (r0 * row_floats + v0 * entry_floats), e00[0], e00[1]);
    wh_load2(lut_floats + (r0 * row_floats + (v0 + 1) * entry_floats), e01[0], e01[1]);
    wh_load2(lut_floats + ((r0 + 1) * row_floats + v0 * entry_floats), e10[0], e10[1]);
    wh_load2(lut_floats + ((r0 + 1) * row_floats + (v0 + 1) * entry_floats), e11[0], e11[1]);
    auto blend = [&](int c) WH_INLINE -> float {
        const float lower = wp::add(wp::mul(e00[c], wp::sub(1.0f, tv)), wp::mul(e01[c], tv));
        const float upper = wp::add(wp::mul(e10[c], wp::sub(1.0f, tv)), wp::mul(e11[c], tv));
        return wp::add(wp::mul(lower, wp::sub(1.0f, tr)), wp::mul(upper, tr));
    };
    const float f90 = wh_fresnel_f90(f0);
    return wp::add(wp::mul(f0, blend(0)), wp::mul(wp::vec3(f90, f90, f90), blend(1)));
};""",
        ("fresnel_f90",),
    ),
    # ---- the dome (scene/device/environment.py's lambdas; ambient.py) ----
    "environment": Piece(ENVIRONMENT_LAMBDAS_CPP),
    # Irradiance E(d) from the SH coefficients at a unit dome-local direction (ambient.py
    # ``dome_irradiance``): band 0 alone where ``amb.sh_bands`` is 1 (branch-free unless
    # ``scalar``).
    "sh_irradiance": Piece(
        f"""auto wh_sh_irradiance = [&](const auto& amb, const wp::vec3& d, const bool scalar) WH_INLINE -> wp::vec3 {{
    const wp::vec3* sh = amb.sh.data;
    const wp::vec3 c = wp::mul(sh[0], {float_literal(SH_C0)});
    const wp::vec3 constant(wp::max(c[0], 0.0f), wp::max(c[1], 0.0f), wp::max(c[2], 0.0f));
    if (scalar && amb.sh_bands == 1) return constant;
    const float x = d[0], y = d[1], z = d[2];
    wp::vec3 e = wp::mul(sh[0], {float_literal(SH_C0)});
    e = wp::add(e, wp::add(wp::add(wp::mul(sh[1], wp::mul({float_literal(SH_C1)}, y)),
                                   wp::mul(sh[2], wp::mul({float_literal(SH_C1)}, z))),
                           wp::mul(sh[3], wp::mul({float_literal(SH_C1)}, x))));
    e = wp::add(e, wp::add(wp::mul(sh[4], wp::mul(wp::mul({float_literal(SH_C2)}, x), y)),
                           wp::mul(sh[5], wp::mul(wp::mul({float_literal(SH_C2)}, y), z))));
    e = wp::add(e, wp::add(wp::mul(sh[6], wp::mul({float_literal(SH_C20)}, wp::sub(wp::mul(wp::mul(3.0f, z), z), 1.0f))),
                           wp::mul(sh[7], wp::mul(wp::mul({float_literal(SH_C2)}, x), z))));
    e = wp::add(e, wp::mul(sh[8], wp::mul({float_literal(SH_C22)}, wp::sub(wp::mul(x, x), wp::mul(y, y)))));
    return wh_select(amb.sh_bands == 1, constant,
                     wp::vec3(wp::max(e[0], 0.0f), wp::max(e[1], 0.0f), wp::max(e[2], 0.0f)));
}};"""
    ),
    # The irradiance the diffuse ambient term sees at world normal n (ambient.py
    # ``ambient_irradiance``): the dome's (its SH in the dome's frame) plus the lights'
    # indirect estimate ``amb.indirect``.
    "ambient_irradiance": Piece(
        """auto wh_dome_irradiance = [&](const auto& env, const auto& amb, const wp::vec3& n, const bool scalar) WH_INLINE
    -> wp::vec3 {
    if (scalar && amb.enabled == 0) return wp::vec3(0.0f);
    const wp::vec3 e = wh_sh_irradiance(amb, wh_normalize(wp::mul(env.world_to_light, n)), scalar);
    return wh_select(amb.enabled == 0, wp::vec3(0.0f), e);
};
auto wh_ambient_irradiance = [&](const auto& env, const auto& amb, const wp::vec3& n, const bool scalar) WH_INLINE
    -> wp::vec3 {
    return wh_select(amb.enabled != 0, wp::add(wh_dome_irradiance(env, amb, n, scalar), amb.indirect), amb.indirect);
};
// Whether the dome's light is the same from every direction (ambient.py ``direction_free``).
auto wh_direction_free = [&](const auto& env, const auto& amb) WH_INLINE -> bool {
    return amb.enabled == 0 || (env.texture < 0 && amb.levels == 0 && amb.sh_bands == 1);
};""",
        ("sh_irradiance",),
    ),
    # The dome's radiance around a direction blurred to a GGX lobe's width (ambient.py
    # ``prefiltered_radiance``), in two steps a row loop can take apart: the lobe's level
    # of detail (``wh_prefilter_lod``) and the lookup at dome-local direction d, its uv
    # and that level (``wh_prefiltered_at``: mip level 0 is the dome's own texture).
    "prefiltered_radiance": Piece(
        f"""auto wh_prefilter_lod = [&](const auto& amb, const float roughness) WH_INLINE -> float {{
    const float width = wp::div(wp::mul(wh_roughness_to_alpha(roughness), (float)amb.base_width), {float_literal(TWO_PI)});
    return width > 1.0f ? wp::log2(width) : 0.0f;
}};
auto wh_mip_fetch = [&](const auto& amb, const int level, const wp::vec2& uv) WH_INLINE -> wp::vec3 {{
    const int k = level - 1;
    return wh_latlong_bilinear(amb.mip_texels.data, amb.mip_offset.data[k], amb.mip_width.data[k],
                               amb.mip_height.data[k], uv);
}};
auto wh_level_radiance = [&](const auto& env, const auto& textures, const auto& texels, const auto& amb,
                             const int level, const wp::vec2& uv) WH_INLINE -> wp::vec3 {{
    if (level == 0) return wh_dome_texture_radiance(env, textures, texels, uv);
    return wh_mip_fetch(amb, level, uv);
}};
auto wh_prefiltered_at = [&](const auto& env, const auto& textures, const auto& texels, const auto& amb,
                             const wp::vec3& d, const wp::vec2& uv, const float lod) WH_INLINE -> wp::vec3 {{
    const float top = (float)amb.levels;
    if (lod >= top) {{
        const float t = wp::min(wp::sub(lod, top), 1.0f);
        return wp::add(wp::mul(wh_mip_fetch(amb, amb.levels, uv), wp::sub(1.0f, t)),
                       wp::mul(wh_sh_irradiance(amb, wh_normalize(d), true), wp::mul(WH_INV_PI, t)));
    }}
    const int l0 = (int)wp::floor(lod);
    const float t = wp::sub(lod, (float)l0);
    const wp::vec3 lower = wh_level_radiance(env, textures, texels, amb, l0, uv);
    if (t <= 0.0f) return lower;
    return wp::add(wp::mul(lower, wp::sub(1.0f, t)), wp::mul(wh_level_radiance(env, textures, texels, amb, l0 + 1, uv), t));
}};
auto wh_prefiltered_radiance = [&](const auto& env, const auto& textures, const auto& texels, const auto& amb,
                                   const wp::vec3& dir_world, const float roughness) WH_INLINE -> wp::vec3 {{
    if (amb.enabled == 0) return wp::vec3(0.0f);
    if (amb.levels == 0) return wh_environment_radiance(env, textures, texels, dir_world);
    const float lod = wh_prefilter_lod(amb, roughness);
    const wp::vec3 d = wp::mul(env.world_to_light, dir_world);
    return wh_prefiltered_at(env, textures, texels, amb, d, wh_environment_uv(d), lod);
}};""",
        ("environment", "roughness_to_alpha", "sh_irradiance"),
    ),
    # Glossy reflection of the dome (ambient.py ``ambient_specular``): the prefiltered
    # radiance along the mirror direction times the split-sum reflectance.
    "ambient_specular": Piece(
        """auto wh_ambient_specular = [&](const auto& env, const auto& textures, const auto& texels, const auto& amb,
                              const wp::vec3& n, const wp::vec3& v, const wp::vec3& f0, const float roughness)
    WH_INLINE -> wp::vec3 {
    if (amb.enabled == 0) return wp::vec3(0.0f);
    const wp::vec3 r = wp::sub(wp::mul(n, wp::mul(2.0f, wp::dot(n, v))), v);
    return wp::cw_mul(wh_env_brdf(amb.brdf_lut, f0, roughness, wp::dot(n, v)),
                      wh_prefiltered_radiance(env, textures, texels, amb, r, roughness));
};""",
        ("env_brdf", "prefiltered_radiance"),
    ),
    # Diffuse ambient light kd / pi * e * (1 - F(n.v)) under irradiance e (ambient.py
    # ``ambient_diffuse``); zero where e has no positive channel.
    "ambient_diffuse": Piece(
        """auto wh_ambient_diffuse = [&](const bool scalar, const wp::vec3& e, const wp::vec3& n, const wp::vec3& v,
                            const wp::vec3& kd, const wp::vec3& f0) WH_INLINE -> wp::vec3 {
    const bool dark = wp::max(wp::max(e[0], e[1]), e[2]) <= 0.0f;
    if (scalar && dark) return wp::vec3(0.0f);
    const wp::vec3 keep = wh_diffuse_view_weight(f0, wp::clamp(wp::dot(n, v), 0.0f, 1.0f));
    return wh_select(dark, wp::vec3(0.0f), wp::cw_mul(wp::cw_mul(wp::mul(kd, WH_INV_PI), e), keep));
};""",
        ("diffuse_view_weight",),
    ),
    # The radiance a surface sends toward v (shading.py ``shade_surface_with``): emission,
    # the lights' ``direct`` sum, the ambient diffuse under irradiance ``e``, the glossy
    # ``specular``, and through glass where there is a dome its radiance ``behind``.
    "surface_radiance": Piece(
        f"""auto wh_surface_radiance = [&](const bool scalar, const bool dome, const wp::vec3& n, const wp::vec3& v,
                             const wp::vec3& albedo, const wp::vec3& kd, const wp::vec3& f0,
                             const wp::vec3& emission, float opacity, float ior, int flags,
                             const wp::vec3& direct, const wp::vec3& e, const wp::vec3& specular,
                             const wp::vec3& behind) WH_INLINE -> wp::vec3 {{
    wp::vec3 c = wp::add(emission, direct);
    c = wp::add(c, wh_ambient_diffuse(scalar, e, n, v, kd, f0));
    c = wp::add(c, specular);
    const bool through = dome && (flags & {int(FLAG_TRANSMISSIVE)}) != 0;
    if (scalar && !through) return c;
    const float o = wp::clamp(opacity, 0.0f, 1.0f);
    const float f = wh_fresnel_dielectric(wp::max(wp::dot(n, v), WH_COS_EPS), ior);
    const wp::vec3 light = wp::mul(wp::cw_mul(albedo, behind), wp::mul(wp::sub(1.0f, o), wp::sub(1.0f, f)));
    return wh_select(through, wp::add(c, light), c);
}};""",
        ("ambient_diffuse", "fresnel_dielectric"),
    ),
    # Unshadowed radiance toward v from one light sample (shading.py ``light_response``).
    "light_response": Piece(
        """auto wh_light_response = [&](const bool scalar, const wp::vec3& wi, const wp::vec3& e_normal,
                           const wp::vec3& irradiance, const wp::vec3& n, const wp::vec3& v, const wp::vec3& kd,
                           const wp::vec3& f0, float roughness) WH_INLINE -> wp::vec3 {
    const wp::vec3 diffuse = wp::cw_mul(wh_brdf_diffuse(n, v, wi, kd, f0), irradiance);
    const float n_dot_l = wp::dot(n, wi);
    if (scalar && n_dot_l <= 0.0f) return diffuse;
    const wp::vec3 specular = wp::mul(wp::cw_mul(wh_brdf_specular(n, v, wi, f0, roughness), e_normal), n_dot_l);
    return wh_select(n_dot_l <= 0.0f, diffuse, wp::add(diffuse, specular));
};""",
        ("brdf_diffuse", "brdf_specular"),
    ),
}


def cpp(*names: str) -> str:
    """C++ text defining the lambdas ``names`` (``wh_<name>``) and every piece they need,
    each after what it needs and once, after the header (inline attribute, constants)."""
    order: list[str] = []

    def visit(name: str) -> None:
        if name in order:
            return
        for need in PIECES[name].needs:
            visit(need)
        order.append(name)

    for name in names:
        visit(name)
    return "\n".join([_HEADER, *(PIECES[name].text for name in order)]) + "\n"
