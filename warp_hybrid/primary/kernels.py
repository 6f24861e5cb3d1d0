"""Every Warp kernel of primary visibility (one compile unit).

* ``camera_points_kernel`` (per vertex, grouped: ``parallel.launch_groups``): every
  point in camera space and, in front of the near plane, projected to the screen, so
  the triangles sharing a vertex reuse it (and see bit-identical corners).
* ``cluster_bounds_kernel`` (one thread per cluster): the bounding box of each run of
  ``CLUSTER_TRIANGLES`` consecutive triangles (meshes are stored whole, still ones in a
  compact order, ``scene.usd.triangle_order``, so a run is a patch of one mesh),
  computed again only when the points move.
* ``coverage_kernel`` (one thread per cluster): a cluster whose box lies wholly outside
  one plane of the view frustum is skipped (its triangles would all fail the same
  plane's trivial reject, so nothing changes but the cost); on the CPU the others are
  set up across the cluster's triangles and rasterized in native code
  (``cover_batch.py``), which leaves the triangles that need clipping or an alpha test
  to the Warp path: triangle by triangle through the trivial frustum rejects, clipping
  (``clipping.py``) and coverage (``coverage.py``) into the per-thread key buffer (every
  triangle on CUDA).
* ``resolve_kernel`` (per pixel): the smallest key over the key slices names the
  nearest triangle; ``hit_record.exact_hit`` gives the pixel's hit record, in a native
  row loop vectorised across pixels (the same C++ statements as ``exact_hit`` and
  ``camera_ray``, so the same bits): the shadow maps' faces, which need no surface (a
  frame's surface pass resolves its own, below).
* ``raycast_kernel`` (per pixel): the reference path, the closest hit through each
  pixel centre from the near plane to the far plane, stepping past cut-away hits, the
  same ``exact_hit`` on the face it finds.  The BVH query is the scene's 4-wide copy
  (``scene/device/wide_bvh.py``, the same answers) where the kernel is given a
  non-empty one, else ``wp.mesh_query_ray``.
* ``surface_kernel`` (per pixel): the surface pass both paths share: the material at
  the hit record, textures filtered over the pixel's footprint, into every other
  G-buffer channel, in a native row loop (the footprints and the surface's frame
  vectorised across pixels; the lambdas of ``surface_at_grad``, so the same bits); a
  material with a normal map goes pixel by pixel through ``surface_at_grad``.  Given the
  coverage pass's key slices it resolves the hit record itself, chunk by chunk, with the
  resolve's statements (``_resolved_surface_span``): the raster frame's G-buffer in one
  pass over the pixels.
* ``listed_primary_kernel`` (per entry of a pixel list, grouped): the ray-cast hit
  record and the surface pass of only the listed pixels, for sub-samples of the focus
  window (``trace.fovea``); a listed pixel that misses gets the background's hit record.

The per-pixel kernels follow the launch layer's ``row0, row_step, cols`` convention
(``parallel.Launcher.launch_pixels``) and write through ``GBufferRows``.  Every pixel
holds its record after every frame, so the G-buffer needs no clear first: the
hit-finding kernels write the background's hit record where no surface is hit, the
surface kernel the background's other channels there (``gbuffer.BACKGROUND``, the
channel table's values), or keeps them where a block held them already
(``GBuffer.background_blocks``).
No back-face culling: the G-buffer must match the ray cast, which sees both sides.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CAMERA_RAY_CPP, CameraGPU, pixel_ray
from ..core.constants import CLUSTER_TRIANGLES, LUMA_709_CPP, luma709
from ..core.gbuffer import BACKGROUND, GBufferRows, Optics
from ..core.native_rows import (
    CHUNK_CPP,
    LAMBDA_HEADER_CPP,
    STREAM_CPP,
    SURFACE_CHUNK_CPU,
    WIDE_VECTOR_CPU_FLAGS,
    chunk_cpp,
)
from ..core.pixel_list import listed_pixel
from ..core.scene_gpu import FLAG_VERTEX_COLOR, SceneGPU
from ..scene.device.surface import (
    SAMPLES_TEXTURES_CPP,
    SURFACE_CPP,
    UV_FOOTPRINT_CPP,
    is_cut_away,
    samples_textures,
    surface_at_grad,
)
from ..scene.device.wide_bvh import WideBVHGPU, WideHit, wide_closest
from ..scene.model import Wrap
from .clipping import (
    IN_FRONT_BIT,
    OUTSIDE_BITS,
    ProjectedPoints,
    in_guard_band,
    project_points,
    raster_clipped,
    to_camera,
)
from .cover_batch import cover_batch
from .coverage import EMPTY_KEY, RasterTarget, raster_triangle
from .hit_record import EXACT_HIT_CPP, exact_hit, pixel_footprint, sample_steps

wp.set_module_options({"enable_backward": False, "cpu_compiler_flags": WIDE_VECTOR_CPU_FLAGS})

# Ray-cast path: at most this many cut-away hits are stepped past per pixel.
MAX_CUTOUT_LAYERS = wp.constant(32)
# A box corner counts as outside a frustum plane only beyond this relative margin, far
# above float32 rounding, so a cluster is never culled where a triangle of it would
# pass the per-triangle test by rounding.
CULL_MARGIN = wp.constant(1.0e-5)


@wp.kernel
def camera_points_kernel(
    points: wp.array(dtype=wp.vec3),
    cam: CameraGPU,
    pts: ProjectedPoints,
    start: int,
    stop: int,
    group: int,
):
    """The scene's ``points`` of this launch item's group (``parallel.group_launch``) in
    camera space (x right, y up, z = view depth), their outcodes and, in front of the near
    plane, on screen (x, y in pixels, view depth): once per vertex rather than once per
    triangle corner (``clipping.project_points``; the points alone are passed, not the
    scene's record, which a launch item copies)."""
    first = start + wp.tid() * group
    project_points(points, cam, pts, first, wp.min(first + group, stop))


@wp.func_native(
    """
char* row = (char*)keys.data + (size_t)k * keys.strides[0] + (size_t)y * keys.strides[1];
if (keys.strides[2] == (int)sizeof(uint64_t)) {
    uint64_t* keys_row = (uint64_t*)row;
    for (int x = x0; x < x1; ++x) keys_row[x] = value;
} else {
    for (int x = x0; x < x1; ++x) *(uint64_t*)(row + (size_t)x * keys.strides[2]) = value;
}
"""
)
def _fill_keys(keys: wp.array3d(dtype=wp.uint64), k: int, y: int, x0: int, x1: int, value: wp.uint64): ...


@wp.kernel
def clear_keys_kernel(
    keys: wp.array3d(dtype=wp.uint64), value: wp.uint64, top: int, rows: int, row0: int, row_step: int, cols: int
):
    """Set rows ``top`` .. ``top + rows`` of every slice of ``keys`` to ``value``: launch
    item (r, c) (``parallel.Launcher.launch_pixels`` over ``slices * rows`` rows) takes
    row ``row0 + r * row_step`` of the slices' rows laid end to end."""
    r, c = wp.tid()
    v = row0 + r * row_step
    k = v // rows
    y = top + v - k * rows
    _fill_keys(keys, k, y, c * cols, wp.min(c * cols + cols, keys.shape[2]), value)


@wp.kernel
def cluster_bounds_kernel(scene: SceneGPU, triangles: int, bounds: wp.array2d(dtype=wp.vec3), start: int, step: int):
    """Clusters start, start + step, ...: the (lower, upper) corners of the bounding box
    of their triangles' points into ``bounds[cluster]``."""
    cluster = start + wp.tid() * step
    first = cluster * CLUSTER_TRIANGLES
    lower = scene.points[scene.indices[3 * first]]
    upper = lower
    for k in range(3 * first, 3 * wp.min(first + CLUSTER_TRIANGLES, triangles)):
        p = scene.points[scene.indices[k]]
        lower = wp.min(lower, p)
        upper = wp.max(upper, p)
    bounds[cluster, 0] = lower
    bounds[cluster, 1] = upper


@wp.func(inline=True)
def _outside_planes(cam: CameraGPU, c: wp.vec3) -> int:
    """The frustum planes camera-space point ``c`` lies beyond (by more than
    ``CULL_MARGIN``), one bit each: near, far, right, left, top, bottom."""
    x = c[0]
    y = c[1]
    z = c[2]
    mx = CULL_MARGIN * (wp.abs(x) + cam.tan_x * wp.abs(z))
    my = CULL_MARGIN * (wp.abs(y) + cam.tan_y * wp.abs(z))
    mz = CULL_MARGIN * (wp.abs(z) + cam.near + cam.far)
    bits = int(0)
    if z < cam.near - mz:
        bits = bits | 1
    if z > cam.far + mz:
        bits = bits | 2
    if x > cam.tan_x * z + mx:
        bits = bits | 4
    if -x > cam.tan_x * z + mx:
        bits = bits | 8
    if y > cam.tan_y * z + my:
        bits = bits | 16
    if -y > cam.tan_y * z + my:
        bits = bits | 32
    return bits


@wp.func(inline=True)
def _box_culled(cam: CameraGPU, lower: wp.vec3, upper: wp.vec3) -> bool:
    """Whether all 8 corners of the box lie beyond one common frustum plane."""
    common = int(63)
    for k in range(8):
        corner = wp.vec3(
            wp.where((k & 1) != 0, upper[0], lower[0]),
            wp.where((k & 2) != 0, upper[1], lower[1]),
            wp.where((k & 4) != 0, upper[2], lower[2]),
        )
        common = common & _outside_planes(cam, to_camera(cam, corner))
    return common != 0


@wp.func(inline=True)
def _cover_triangle(scene: SceneGPU, cam: CameraGPU, pts: ProjectedPoints, target: RasterTarget, tri: int):
    """Rasterize triangle ``tri`` (corners from ``camera_points_kernel``) into ``target``."""
    i0 = scene.indices[3 * tri]
    i1 = scene.indices[3 * tri + 1]
    i2 = scene.indices[3 * tri + 2]
    # Trivial rejects: wholly behind the near plane, beyond the far plane, or outside
    # one side plane of the view frustum (the corners' outcodes share a bit).
    common = pts.outcodes[i0] & pts.outcodes[i1] & pts.outcodes[i2]
    if (common & OUTSIDE_BITS) != 0:
        return

    if (common & IN_FRONT_BIT) != 0:
        s0 = pts.screen[i0]
        s1 = pts.screen[i1]
        s2 = pts.screen[i2]
        if in_guard_band(cam, s0) and in_guard_band(cam, s1) and in_guard_band(cam, s2):
            raster_triangle(s0, s1, s2, tri, scene, cam, target)
            return

    raster_clipped(tri, scene, cam, pts, target)


@wp.func(inline=True)
def _cover_cluster(
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    target: RasterTarget,
    bounds: wp.array2d(dtype=wp.vec3),
    triangles: int,
    cluster: int,
):
    """Rasterize the triangles of ``cluster`` (its box in ``bounds``; ``triangles`` in all)
    into ``target``, unless the box lies outside the view frustum."""
    if _box_culled(cam, bounds[cluster, 0], bounds[cluster, 1]):
        return
    first = cluster * CLUSTER_TRIANGLES
    stop = wp.min(first + CLUSTER_TRIANGLES, triangles)
    # (the cluster set up across its triangles in native code, on the CPU; the ones it
    # leaves, one at a time)
    left = cover_batch(scene, cam, pts, target, first, stop)
    if left != wp.uint64(0):
        for tri in range(first, stop):
            if ((left >> wp.uint64(tri - first)) & wp.uint64(1)) != wp.uint64(0):
                _cover_triangle(scene, cam, pts, target, tri)


@wp.kernel
def coverage_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    target: RasterTarget,
    bounds: wp.array2d(dtype=wp.vec3),
    triangles: int,
    start: int,
    step: int,
):
    """Rasterize the triangles of clusters start, start + step, ... (boxes in
    ``bounds``; ``triangles`` in all) into ``target``, skipping clusters outside the
    view frustum."""
    _cover_cluster(scene, cam, pts, target, bounds, triangles, start + wp.tid() * step)


@wp.kernel
def cover_rows_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    target: RasterTarget,
    bounds: wp.array2d(dtype=wp.vec3),
    triangles: int,
    clusters: int,
    clear: wp.uint64,
    row_begin: int,
    row_end: int,
):
    """One launch item, a band of rows of a small scene (or of one thread's whole frame):
    set rows ``row_begin`` up to ``row_end`` of ``target``'s slot to ``clear``, then
    rasterize every cluster not culled into those rows only."""
    band = RasterTarget()
    band.keys = target.keys
    band.slot = target.slot
    band.mode = target.mode
    band.row_begin = row_begin
    band.row_end = row_end
    for y in range(row_begin, row_end):
        _fill_keys(target.keys, target.slot, y, 0, target.keys.shape[2], clear)
    for cluster in range(clusters):
        _cover_cluster(scene, cam, pts, band, bounds, triangles, cluster)


@wp.func(inline=True)
def _write_hit_record(gb: GBufferRows, i: int, tri: int, hit: wp.vec3):
    """Store the hit record (triangle, depth, barycentrics) at flat index ``i``."""
    gb.triangle_id[i] = tri
    gb.depth[i] = hit[0]
    gb.barycentric[i] = wp.vec2(hit[1], hit[2])


@wp.func(inline=True)
def _write_miss_record(gb: GBufferRows, i: int):
    """Store the background's hit record at flat index ``i``."""
    gb.triangle_id[i] = wp.static(int(BACKGROUND["triangle_id"]))
    gb.depth[i] = wp.static(float(BACKGROUND["depth"]))
    gb.barycentric[i] = wp.vec2(wp.static(float(BACKGROUND["barycentric"])))


@wp.func(inline=True)
def _write_surface(
    gb: GBufferRows, i: int, scene: SceneGPU, cam: CameraGPU, tri: int, b: wp.vec2, d: wp.vec3, channels: int
):
    """Evaluate the surface at barycentrics ``b`` of ``tri`` (textures filtered over the
    pixel's footprint; ``d`` is the camera ray) into every other channel at ``i`` (the
    optional ones where ``channels`` has their bit, ``SURFACE_EMISSION``...)."""
    footprint = wp.vec4(0.0, 0.0, 0.0, 0.0)
    if samples_textures(scene, tri):
        footprint = pixel_footprint(scene, cam, tri, d)
    h = surface_at_grad(scene, tri, b[0], b[1], d, footprint)
    gb.position[i] = h.position
    gb.normal[i] = h.normal
    if (channels & wp.static(SURFACE_GEOMETRIC_NORMAL)) != 0:
        gb.geometric_normal[i] = h.geometric_normal
    gb.albedo[i] = h.albedo
    gb.specular[i] = h.specular
    if (channels & wp.static(SURFACE_EMISSION)) != 0:
        gb.emission[i] = h.emission
    optics = Optics()
    optics.reflectivity = luma709(h.specular)
    optics.ior = h.ior
    optics.opacity = h.opacity
    optics.roughness = h.roughness
    gb.optics[i] = optics
    gb.material_id[i] = h.material


# C++ the row loops over a row's triangles share (the resolve's and the surface pass's):
# the chunk's lane arrays of triangle corners; lane j's corners ``a, b, c`` stored into
# them; lane j's camera ray ``d`` (``CAMERA_RAY_CPP`` through its pixel's sample point,
# needing ``py``) and its corners ``p0, p1, p2`` read back.
_CORNER_LANES_CPP = (
    "float ax[CHUNK], ay[CHUNK], az[CHUNK], bx[CHUNK], by[CHUNK], bz[CHUNK], cx[CHUNK], cy[CHUNK], cz[CHUNK];"
)
_STORE_CORNERS_CPP = """
ax[j] = a[0]; ay[j] = a[1]; az[j] = a[2];
bx[j] = b[0]; by[j] = b[1]; bz[j] = b[2];
cx[j] = c[0]; cy[j] = c[1]; cz[j] = c[2];
"""
_LANE_RAY_CPP = f"""
const float px = wp::add((float)(xs + j), cam.sample[0]);
{CAMERA_RAY_CPP}
const wp::vec3 d = ray;
const wp::vec3 p0(ax[j], ay[j], az[j]);
const wp::vec3 p1(bx[j], by[j], bz[j]);
const wp::vec3 p2(cx[j], cy[j], cz[j]);
"""


def _corner_indices_cpp(triangle: str, attributes: bool) -> str:
    """C++: lane j's triangle ``triangle`` (a C++ expression of ``j``; negative: none) to
    int lane arrays, ahead of the loop that gathers by them: ``kc``, its first corner
    (3 x triangle, 0 for none), and ``ia, ib, ic``, the first float of each corner's point
    (3 x ``index``); with ``attributes`` also ``kt`` and ``kn``, the first float of its
    corner uvs and corner normals (2 and 3 x ``kc``).  An index a gather loads from an int
    array stays 32 bits: one the gather's own loop multiplied, the compiler widened to 64
    (gathers of 8 lanes instead of 16)."""
    attribute_arrays = ", kt[CHUNK], kn[CHUNK]" if attributes else ""
    attribute_lanes = " kt[j] = 2 * k; kn[j] = 3 * k;" if attributes else ""
    return f"""
int kc[CHUNK], ia[CHUNK], ib[CHUNK], ic[CHUNK]{attribute_arrays};
for (int j = 0; j < n; ++j) {{
    const int tri = {triangle};
    const int k = 3 * (tri >= 0 ? tri : 0);
    kc[j] = k;{attribute_lanes}
}}
for (int j = 0; j < n; ++j) {{
    ia[j] = 3 * index[kc[j]]; ib[j] = 3 * index[kc[j] + 1]; ic[j] = 3 * index[kc[j] + 2];
}}"""


#: A chunk whose runs of pixels on one triangle average under this many pixels reads each
#: pixel's corners (the resolve's step (2), the surface row loop's step (1)); the others
#: load them once a run.
SHORT_RUN_PIXELS = 4

# C++ the resolve's row loop and the resolving surface loop share (given ``keys``, the
# coverage pass's key slices, and row ``y``): the empty key and the row's keys in the
# first slice; then for a chunk (``xs``, ``n`` lanes) the smallest of each pixel's keys
# over the slices into ``key``.
_ROW_KEYS_CPP = f"""const wp::uint64 empty = {int(EMPTY_KEY.value)}ull;
const wp::uint64* first_keys = (const wp::uint64*)((const char*)keys.data + (size_t)y * keys.strides[1]);
"""
_SMALLEST_KEYS_CPP = """
    for (int j = 0; j < n; ++j) key[j] = first_keys[xs + j];
    for (int s = 1; s < (int)keys.shape[0]; ++s) {
        const wp::uint64* slice = (const wp::uint64*)((const char*)first_keys + (size_t)s * keys.strides[0]);
        for (int j = 0; j < n; ++j) key[j] = wp::min(key[j], slice[xs + j]);
    }"""

# The resolve's row loop: a chunk of pixels at a time, (1) the smallest key over the
# slices, (2) the corners of each pixel's triangle (none for an empty key; gathered, or
# once a run of pixels on one triangle: ``SHORT_RUN_PIXELS``),
# (3) the camera ray and ``EXACT_HIT_CPP`` in a loop of plain arithmetic over the chunk
# (no memory access but its own scratch, no branch: the compiler vectorises it across
# pixels), (4) the hit record, or the background's for an empty key (a chunk of empty
# keys alone takes the background's and skips (2) and (3)), written in whole cache lines
# (``STREAM_CPP``).  Every array it writes is contiguous (``GBufferRows`` views whole
# buffers).
_RESOLVE_SPAN_CPP = (
    CHUNK_CPP
    + LAMBDA_HEADER_CPP
    + STREAM_CPP
    + f"""
{_ROW_KEYS_CPP}const wp::vec3* corners = points.data;
const int* index = indices.data;
const wp::vec3 o = cam.origin;
const wp::vec3 fwd = cam.forward;
const float py = wp::add((float)y, cam.sample[1]);
const size_t row = (size_t)y * (size_t)cam.width;
wp::uint64 key[CHUNK];
{_CORNER_LANES_CPP}
float hit_t[CHUNK], hit_u[CHUNK], hit_v[CHUNK];
int tri_v[CHUNK];
for (int xs = x0; xs < x1; xs += CHUNK) {{
    const int n = x1 - xs < CHUNK ? x1 - xs : CHUNK;
{_SMALLEST_KEYS_CPP}
    int hits = 0;
    for (int j = 0; j < n; ++j) hits += key[j] != empty ? 1 : 0;
    if (hits == 0) {{  // (a chunk of background alone: its miss values, no corners or rays)
        for (int j = 0; j < n; ++j) {{
            tri_v[j] = miss_triangle;
            hit_t[j] = miss_depth;
            hit_u[j] = miss_barycentric;
            hit_v[j] = miss_barycentric;
        }}
    }} else {{
    // (the corners as the surface pass takes them: where the chunk's runs of pixels on one
    // triangle are short, each pixel's own, gathered across the chunk; else once a run)
    int runs = 0;
    for (int j = 0; j < n; ++j) {{
        tri_v[j] = key[j] != empty ? (int)(key[j] & 0xFFFFFFFFull) : -1;
        runs += (j == 0 || tri_v[j] != tri_v[j - 1]) ? 1 : 0;
    }}
    if (runs * {SHORT_RUN_PIXELS} > n) {{
        const float* P = (const float*)corners;
        {_corner_indices_cpp("tri_v[j]", attributes=False)}
        #pragma clang loop vectorize(enable)
        for (int j = 0; j < n; ++j) {{
            const bool hit = tri_v[j] >= 0;
            ax[j] = hit ? P[ia[j]] : 0.0f; ay[j] = hit ? P[ia[j] + 1] : 0.0f; az[j] = hit ? P[ia[j] + 2] : 0.0f;
            bx[j] = hit ? P[ib[j]] : 0.0f; by[j] = hit ? P[ib[j] + 1] : 0.0f; bz[j] = hit ? P[ib[j] + 2] : 0.0f;
            cx[j] = hit ? P[ic[j]] : 0.0f; cy[j] = hit ? P[ic[j] + 1] : 0.0f; cz[j] = hit ? P[ic[j] + 2] : 0.0f;
        }}
    }} else {{
    for (int run = 0; run < n;) {{
        const int tri = tri_v[run];
        int end = run + 1;
        while (end < n && tri_v[end] == tri) ++end;
        wp::vec3 a(0.0f), b(0.0f), c(0.0f);
        if (tri >= 0) {{
            const int k = 3 * tri;
            a = corners[index[k]];
            b = corners[index[k + 1]];
            c = corners[index[k + 2]];
        }}
        for (int j = run; j < end; ++j) {{
            {_STORE_CORNERS_CPP}
        }}
        run = end;
    }}
    }}
    for (int j = 0; j < n; ++j) {{
        {_LANE_RAY_CPP}
        {EXACT_HIT_CPP}
        hit_t[j] = eh_t;
        hit_u[j] = rt_bu;
        hit_v[j] = rt_bv;
    }}
    for (int j = 0; j < n; ++j) {{
        const bool hit = key[j] != empty;
        tri_v[j] = hit ? tri_v[j] : miss_triangle;
        hit_t[j] = hit ? hit_t[j] : miss_depth;
        hit_u[j] = hit ? hit_u[j] : miss_barycentric;
        hit_v[j] = hit ? hit_v[j] : miss_barycentric;
    }}
    }}
    wh_write_ints(gb.triangle_id.data + row + xs, n, tri_v);
    wh_write_floats(gb.depth.data + row + xs, 1, n, hit_t, nullptr, nullptr, nullptr);
    wh_write_floats((float*)(gb.barycentric.data + row + xs), 2, n, hit_u, hit_v, nullptr, nullptr);
}}
WH_STREAM_FENCE();
"""
)


@wp.func_native(_RESOLVE_SPAN_CPP)
def _resolve_span(
    points: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    cam: CameraGPU,
    keys: wp.array3d(dtype=wp.uint64),
    gb: GBufferRows,
    miss_triangle: int,
    miss_depth: float,
    miss_barycentric: float,
    y: int,
    x0: int,
    x1: int,
):
    """The hit records of pixels ``x0 <= x < x1`` of row ``y`` (``_RESOLVE_SPAN_CPP``): the
    same bits as ``exact_hit`` on ``pixel_ray`` pixel by pixel."""
    ...


@wp.kernel
def resolve_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    keys: wp.array3d(dtype=wp.uint64),
    gb: GBufferRows,
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: the nearest key over all key slices -> the hit record (the
    background's where every slice is empty), in a native row loop."""
    r, c = wp.tid()
    y = row0 + r * row_step
    first = c * cols
    stop = wp.min(first + cols, cam.width)
    if first < stop:
        _resolve_span(
            scene.points,
            scene.indices,
            cam,
            keys,
            gb,
            wp.static(int(BACKGROUND["triangle_id"])),
            wp.static(float(BACKGROUND["depth"])),
            wp.static(float(BACKGROUND["barycentric"])),
            y,
            first,
            stop,
        )


@wp.func
def _closest(scene: SceneGPU, wide: WideBVHGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> WideHit:
    """The nearest hit of ``o + t d``, 0 <= t < ``max_t``: through ``wide`` where it is
    not empty, else ``wp.mesh_query_ray`` (the same answers)."""
    if wide.nodes > 0:
        return wide_closest(wide, o, d, max_t)
    q = wp.mesh_query_ray(scene.mesh, o, d, max_t)
    h = WideHit()
    h.result = q.result
    h.face = q.face
    h.t = q.t
    h.u = q.u
    h.v = q.v
    h.normal = q.normal
    return h


@wp.func(inline=True)
def _cast(scene: SceneGPU, wide: WideBVHGPU, cam: CameraGPU, gb: GBufferRows, x: int, y: int):
    """The ray-cast hit record of pixel (x, y), if its ray hits anything (``_closest``)."""
    d = pixel_ray(cam, x, y)
    t_base = cam.near
    for _layer in range(MAX_CUTOUT_LAYERS):
        q = _closest(scene, wide, cam.origin + d * t_base, d, cam.far - t_base)
        if not q.result:
            return
        t = t_base + q.t
        if not is_cut_away(scene, q.face, q.u, q.v):
            # The BVH picks the face; depth and barycentrics are recomputed exactly from
            # the camera origin (the query works relative to far-away corners in float32,
            # off by up to tens of percent on 1e4-sized triangles seen up close).
            _write_hit_record(gb, y * cam.width + x, q.face, exact_hit(scene, cam, q.face, d))
            return
        t_base = t + 1.0e-5 * t


@wp.kernel
def raycast_kernel(
    scene: SceneGPU, wide: WideBVHGPU, cam: CameraGPU, gb: GBufferRows, row0: int, row_step: int, cols: int
):
    """Per pixel: the closest hit between the near and far planes (``wide``: the scene's
    4-wide BVH copy, or an empty one for Warp's query), stepping past hits in cut-out
    holes -> the hit record (the background's where nothing is hit)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, cam.width)):
        _write_miss_record(gb, y * cam.width + x)
        if scene.mesh != wp.uint64(0):
            _cast(scene, wide, cam, gb, x, y)


def _background_cpp(channel: str) -> str:
    """C++ literal of ``gbuffer.BACKGROUND[channel]`` (a float channel's value)."""
    return f"{float(BACKGROUND[channel])!r}f"


#: The surface row loop's lane arrays of each channel it writes (component by component;
#: ``material_id`` in ``out_mid``).
_SURFACE_LANES = {
    "position": ("qx", "qy", "qz"),
    "normal": ("sx", "sy", "sz"),
    "geometric_normal": ("gx", "gy", "gz"),
    "albedo": ("ar", "ag", "ab"),
    "specular": ("kr", "kg", "kb"),
    "emission": ("er", "eg", "eb"),
    "optics": ("o_refl", "o_ior", "o_opac", "o_rough"),
}


def _background_lanes_cpp(keep: str) -> str:
    """C++ statements: lane j's channels (``_SURFACE_LANES``, ``out_mid``) keep their values
    where ``keep`` holds, else take the background's (``gbuffer.BACKGROUND``)."""
    lines = [
        f"{lane}[j] = {keep} ? {lane}[j] : {_background_cpp(channel)};"
        for channel, lanes in _SURFACE_LANES.items()
        for lane in lanes
    ]
    lines.append(f"out_mid[j] = {keep} ? out_mid[j] : {int(BACKGROUND['material_id'])};")
    return " ".join(lines)


#: Bits of the surface pass's ``channels``: the channels it writes only where asked.  The
#: emission (``GBuffer.surface_writes_emission``: a scene without an emissive material
#: leaves the channel at the background's zero, once it is there); the geometric normal
#: (``PrimaryVisibility.geometric_normals``: only traced rays' offsets and the shadow
#: maps' lookups read it).
SURFACE_EMISSION = 1
SURFACE_GEOMETRIC_NORMAL = 2
#: Every optional channel.
SURFACE_ALL = SURFACE_EMISSION | SURFACE_GEOMETRIC_NORMAL
_OPTIONAL_CHANNELS = {"emission": SURFACE_EMISSION, "geometric_normal": SURFACE_GEOMETRIC_NORMAL}

#: C++: the chunk's channels written to the G-buffer's rows from the lane arrays.
_WRITE_LANES_CPP = (
    " ".join(
        (f"if ((channels & {_OPTIONAL_CHANNELS[channel]}) != 0) " if channel in _OPTIONAL_CHANNELS else "")
        + f"wh_write_floats((float*)(gb.{channel}.data + row + xs), {len(lanes)}, n, "
        f"{', '.join(lanes + ('nullptr',) * (4 - len(lanes)))});"
        for channel, lanes in _SURFACE_LANES.items()
    )
    + " wh_write_ints(gb.material_id.data + row + xs, n, out_mid);"
)


# The pieces ``_surface_span_cpp`` adds to resolve the raster frame's hit record itself
# (given ``keys``, the coverage pass's key slices, and the background's hit record
# ``miss_triangle``, ``miss_depth``, ``miss_barycentric``): the row's keys and the lanes of
# the record; (0) each pixel's triangle from the smallest key over the slices, stored into
# the row's triangle ids but where a whole block keeps the background record it holds, and
# ``hits`` counted; the background's depth and barycentrics written with a background
# chunk's other channels; in (2)'s loop ``EXACT_HIT_CPP`` on the lane's corners and camera
# ray; the record's depth and barycentrics written with the other channels.
_RESOLVED_ROW_CPP = f"""{_ROW_KEYS_CPP}const wp::vec3 fwd = cam.forward;
int* const tri_ids = gb.triangle_id.data + row;
float hit_t[CHUNK], hit_u[CHUNK], hit_v[CHUNK];
"""
_RESOLVED_CHUNK_CPP = (
    """{
        wp::uint64 key[CHUNK];"""
    + _SMALLEST_KEYS_CPP
    + """
        int tri_v[CHUNK];
        for (int j = 0; j < n; ++j) {
            tri_v[j] = key[j] != empty ? (int)(key[j] & 0xFFFFFFFFull) : miss_triangle;
            hits += key[j] != empty ? 1 : 0;
        }
        if (!(hits == 0 && whole && blocks[xs / CHUNK] != 0))
            for (int j = 0; j < n; ++j) tri_ids[xs + j] = tri_v[j];
    }"""
)
_HIT_RECORD_WRITE_CPP = """
        wh_write_floats(gb.depth.data + row + xs, 1, n, hit_t, nullptr, nullptr, nullptr);
        wh_write_floats((float*)(gb.barycentric.data + row + xs), 2, n, hit_u, hit_v, nullptr, nullptr);"""
_MISS_RECORD_CPP = (
    """
        for (int j = 0; j < n; ++j) {
            hit_t[j] = miss_depth; hit_u[j] = miss_barycentric; hit_v[j] = miss_barycentric;
        }"""
    + _HIT_RECORD_WRITE_CPP
)
_RESOLVED_HIT_CPP = f"""
        {EXACT_HIT_CPP}
        const bool hit_lane = tris[xs + j] >= 0;
        hit_t[j] = hit_lane ? eh_t : miss_depth;
        hit_u[j] = hit_lane ? rt_bu : miss_barycentric;
        hit_v[j] = hit_lane ? rt_bv : miss_barycentric;
        bu[j] = hit_lane ? rt_bu : 0.0f;
        bv[j] = hit_lane ? rt_bv : 0.0f;"""


# The surface pass's row loop: a chunk of pixels at a time, each pixel's material and
# whether the chunk samples a texture (where none of its materials does, its uvs, their
# footprint and the surface's uv are left out: only texture lookups read them), (1) each
# pixel's triangle corners, corner uvs and normals and its barycentrics (none for the
# background): loaded once for a run of pixels on one triangle, or for each pixel where the
# chunk's runs are short (``SHORT_RUN_PIXELS``: on the CPU 16-byte loads lane by lane, their
# components picked out in registers; on CUDA by index), (2) the camera ray, the uv footprint
# (``UV_FOOTPRINT_CPP``) and the surface's frame (``wh_surface_frame``) as plain arithmetic
# over the chunk (the compiler vectorises it across pixels), (3) the materials
# (``wh_material``, its textures filtered over the footprint): each material whose only
# texture is its diffuse colour over the chunk, its taps too, the others pixel by pixel,
# (4) every channel but the hit record, the background's values where no surface is hit,
# from lane arrays (``_SURFACE_LANES``) in whole cache lines (``STREAM_CPP``).  A pixel
# whose material has a normal map is left for the scalar path (``surface_at_grad``, which
# writes all of it after); the loop returns how many it left.  The same lambdas as
# ``surface_at_grad``, so the same bits.


#: The surface loop's taps of a material's diffuse texture that repeats in both axes (given
#: the binding ``t``, the lanes' texture uvs ``su, sv``, their level ``level`` and blend
#: toward the next ``frac``): across lanes each level's bilinear footprint
#: (``wh_repeat_footprint``: background lanes tap harmlessly); then on the CPU lane by lane,
#: only the material's lanes (the others' values are dropped), each texel one 16-byte load
#: and its channels blended at once (``wh_bilinear4``; a gather across lanes, three a
#: texel, took a cycle or more a float), the coarse level only where it is blended in; on
#: CUDA channel by channel (``wh_footprint_channel``).  ``wh_bilinear_repeat_channel``'s
#: and ``wh_mip_blend``'s operations, then the binding's scale and bias: the same bits.
_REPEAT_TAPS_CPP = """
                int a00[CHUNK], a01[CHUNK], a10[CHUNK], a11[CHUNK], b00[CHUNK], b01[CHUNK], b10[CHUNK], b11[CHUNK];
                float ax[CHUNK], ay[CHUNK], bx[CHUNK], by[CHUNK];
                bool fine_finite[CHUNK], coarse_finite[CHUNK];
                for (int j = 0; j < n; ++j) {
                    const int l = level[j];
                    const int u = wp::min(l + 1, t.levels - 1);
                    const int fine = l == 0 ? t.offset : t.level_offsets[l];
                    const int coarse = t.level_offsets[u];
                    const int fw = wp::max(t.width >> l, 1), fh = wp::max(t.height >> l, 1);
                    const int cw = wp::max(t.width >> u, 1), ch = wp::max(t.height >> u, 1);
                    fine_finite[j] = wh_repeat_footprint(fine, fw, fh, su[j], sv[j], a00[j], a01[j], a10[j], a11[j],
                                                         ax[j], ay[j]);
                    coarse_finite[j] = wh_repeat_footprint(coarse, cw, ch, su[j], sv[j], b00[j], b01[j], b10[j],
                                                           b11[j], bx[j], by[j]);
                }
#if defined(__CUDA_ARCH__)
                const wp::vec4* texels = scene.texels.data;
                for (int j = 0; j < n; ++j) {
                    auto channel = [&](int k) WH_INLINE -> float {
                        const float a = wh_footprint_channel(texels, a00[j], a01[j], a10[j], a11[j], ax[j], ay[j],
                                                             fine_finite[j], k);
                        const float b = wh_footprint_channel(texels, b00[j], b01[j], b10[j], b11[j], bx[j], by[j],
                                                             coarse_finite[j], k);
                        return wp::add(wp::mul(wh_mip_blend(a, b, frac[j]), t.scale[k]), t.bias[k]);
                    };
                    dr[j] = channel(0); dg[j] = channel(1); db[j] = channel(2);
                }
#else
                const float* flat = (const float*)scene.texels.data;
                const wh_float4 scale{t.scale[0], t.scale[1], t.scale[2], t.scale[3]};
                const wh_float4 bias{t.bias[0], t.bias[1], t.bias[2], t.bias[3]};
                #pragma clang loop vectorize(disable)
                for (int j = 0; j < n; ++j) {
                    if (mids[j] != mid) {
                        dr[j] = dg[j] = db[j] = 0.0f;
                        continue;
                    }
                    const wh_float4 zero = 0.0f;
                    const wh_float4 a = fine_finite[j] ? wh_bilinear4(flat, 4, a00[j], a01[j], a10[j], a11[j], ax[j], ay[j])
                                                       : zero;
                    wh_float4 filtered = a;
                    if (frac[j] > 0.0f) {
                        const wh_float4 b = coarse_finite[j] ? wh_bilinear4(flat, 4, b00[j], b01[j], b10[j], b11[j], bx[j],
                                                                            by[j])
                                                             : zero;
                        filtered = wh_lerp4(a, b, frac[j]);
                    }
                    const wh_float4 scaled = filtered * scale;
                    const wh_float4 c = scaled + bias;
                    dr[j] = c[0]; dg[j] = c[1]; db[j] = c[2];
                }
#endif"""


#: The surface loop's step (1) for a chunk of short runs on CUDA: each lane's corners, uvs
#: (where the chunk samples a texture) and corner normals gathered across lanes by their
#: indices (``_corner_indices_cpp``), zero where the pixel sees no surface.
_GATHERED_CORNERS_CUDA_CPP = f"""
        {_corner_indices_cpp("tris[xs + j]", attributes=True)}
        for (int j = 0; j < n; ++j) {{
            const int tri = tris[xs + j];
            const bool hit = tri >= 0;
            const int t2 = kt[j], n3 = kn[j];
            ax[j] = hit ? P[ia[j]] : 0.0f; ay[j] = hit ? P[ia[j] + 1] : 0.0f; az[j] = hit ? P[ia[j] + 2] : 0.0f;
            bx[j] = hit ? P[ib[j]] : 0.0f; by[j] = hit ? P[ib[j] + 1] : 0.0f; bz[j] = hit ? P[ib[j] + 2] : 0.0f;
            cx[j] = hit ? P[ic[j]] : 0.0f; cy[j] = hit ? P[ic[j] + 1] : 0.0f; cz[j] = hit ? P[ic[j] + 2] : 0.0f;
            const bool uv = hit && uv_wanted;
            u0[j] = uv ? UV[t2] : 0.0f; v0[j] = uv ? UV[t2 + 1] : 0.0f;
            u1[j] = uv ? UV[t2 + 2] : 0.0f; v1[j] = uv ? UV[t2 + 3] : 0.0f;
            u2[j] = uv ? UV[t2 + 4] : 0.0f; v2[j] = uv ? UV[t2 + 5] : 0.0f;
            mx[j] = hit ? NN[n3] : 0.0f; my[j] = hit ? NN[n3 + 1] : 0.0f; mz[j] = hit ? NN[n3 + 2] : 0.0f;
            nx1[j] = hit ? NN[n3 + 3] : 0.0f; ny1[j] = hit ? NN[n3 + 4] : 0.0f; nz1[j] = hit ? NN[n3 + 5] : 0.0f;
            ox[j] = hit ? NN[n3 + 6] : 0.0f; oy[j] = hit ? NN[n3 + 7] : 0.0f; oz[j] = hit ? NN[n3 + 8] : 0.0f;
        }}"""

#: The same on the CPU: lane by lane the loads as 16-byte vectors (a corner's point, its
#: three corner normals' nine floats as three overlapping vectors, its uvs as two), zero
#: where the pixel sees no surface (and past the chunk's end), then each component of the
#: sixteen lanes picked out in registers into its lane array (``wh_unpack16``): a
#: gather across lanes took a cycle or more a lane, 27 of them a chunk.  (A point's fourth
#: float is the next point's first, or past the last one the points' spare one,
#: ``native_rows.spare_padded``.)
_LOADED_CORNERS_CPP = """
        static_assert(CHUNK == 16, "a chunk is one register of lanes");
        wh_float4 pa[16], pb[16], pc[16], na[16], nb[16], nc[16], ta[16], tb[16];
        #pragma clang loop vectorize(disable)
        for (int j = 0; j < 16; ++j) {
            const wh_float4 zero = 0.0f;
            pa[j] = zero; pb[j] = zero; pc[j] = zero; na[j] = zero; nb[j] = zero; nc[j] = zero; ta[j] = zero;
            tb[j] = zero;
            const int tri = j < n ? tris[xs + j] : -1;
            if (tri < 0) continue;
            const int k = 3 * tri;
            pa[j] = wh_load4(P + 3 * index[k]);
            pb[j] = wh_load4(P + 3 * index[k + 1]);
            pc[j] = wh_load4(P + 3 * index[k + 2]);
            na[j] = wh_load4(NN + 3 * k);
            nb[j] = wh_load4(NN + 3 * k + 4);
            nc[j] = wh_load4(NN + 3 * k + 5);
            if (uv_wanted) {
                ta[j] = wh_load4(UV + 2 * k);
                tb[j] = wh_load4(UV + 2 * k + 2);
            }
        }
        wh_unpack16(pa, ax, ay, az, nullptr);
        wh_unpack16(pb, bx, by, bz, nullptr);
        wh_unpack16(pc, cx, cy, cz, nullptr);
        wh_unpack16(na, mx, my, mz, nx1);
        wh_unpack16(nb, ny1, nz1, ox, oy);
        wh_unpack16(nc, nullptr, nullptr, nullptr, oz);
        wh_unpack16(ta, u0, v0, u1, v1);
        wh_unpack16(tb, nullptr, nullptr, u2, v2);"""

#: The raster G-buffer's barycentrics of a chunk of short runs (the surface pass that does
#: not resolve), zero where the pixel sees no surface.
_BARYCENTRICS_CPP = """for (int j = 0; j < n; ++j) {
            const bool hit = tris[xs + j] >= 0;
            const wp::vec2 w = bary[xs + j]; bu[j] = hit ? w[0] : 0.0f; bv[j] = hit ? w[1] : 0.0f;
        }"""


def _surface_span_cpp(resolve: bool) -> str:
    """The C++ of the surface row loop (above): without ``resolve`` over the hit record in
    the G-buffer; with it the raster frame's resolve too (``_resolved_surface_span``): (0)
    at each chunk's start the smallest key over the slices (the resolve's step (1)) names
    each pixel's triangle, stored into the row's triangle ids, whose reads below then hit
    the cache; the barycentrics and depth come from ``EXACT_HIT_CPP`` in (2)'s loop over
    the corners and the camera ray (1) and (2) have there already, and the hit record's
    depth and barycentrics are written with the other channels.  The resolve's
    statements on the same corners and rays, so the same bits."""
    return (
        chunk_cpp(SURFACE_CHUNK_CPU)
        + SURFACE_CPP
        + STREAM_CPP
        + f"""
const wp::vec3* corners = scene.points.data;
const int* index = scene.indices.data;
const wp::vec2* uvs = scene.corner_uvs.data;
const wp::vec3* corner_normals = scene.corner_normals.data;
const wp::vec3 o = cam.origin;
const float py = wp::add((float)y, cam.sample[1]);
const size_t row = (size_t)y * (size_t)cam.width;
{_RESOLVED_ROW_CPP if resolve else ""}const int* tris = gb.triangle_id.data + row;
const wp::vec2* bary = gb.barycentric.data + row;
// which of the row's blocks of CHUNK pixels hold the background record (``GBuffer.background_blocks``)
int* const blocks = (int*)((char*)background_blocks.data + (size_t)y * background_blocks.strides[0]);
{_CORNER_LANES_CPP}
float u0[CHUNK], v0[CHUNK], u1[CHUNK], v1[CHUNK], u2[CHUNK], v2[CHUNK];
float mx[CHUNK], my[CHUNK], mz[CHUNK], nx1[CHUNK], ny1[CHUNK], nz1[CHUNK], ox[CHUNK], oy[CHUNK], oz[CHUNK];
float bu[CHUNK], bv[CHUNK], f0[CHUNK], f1[CHUNK], f2[CHUNK], f3[CHUNK];
float qx[CHUNK], qy[CHUNK], qz[CHUNK], gx[CHUNK], gy[CHUNK], gz[CHUNK], sx[CHUNK], sy[CHUNK], sz[CHUNK];
float tu[CHUNK], tv[CHUNK], su[CHUNK], sv[CHUNK], frac[CHUNK], dr[CHUNK], dg[CHUNK], db[CHUNK];
// the chunk's channels as they are written (position, normals: q*, s*, g* above)
float ar[CHUNK], ag[CHUNK], ab[CHUNK], kr[CHUNK], kg[CHUNK], kb[CHUNK], er[CHUNK], eg[CHUNK], eb[CHUNK];
float o_refl[CHUNK], o_ior[CHUNK], o_opac[CHUNK], o_rough[CHUNK];
int mids[CHUNK], level[CHUNK], out_mid[CHUNK];
bool away[CHUNK];
int left = 0;
int xs = x0;
// lane j's material values (the frame's are in q*, g*, s*, away)
auto keep_material = [&](int j, int mid, const wp::vec3& albedo, const wp::vec3& specular, const wp::vec3& emission,
                         float roughness, float opacity, float ior) WH_INLINE {{
    ar[j] = albedo[0]; ag[j] = albedo[1]; ab[j] = albedo[2];
    kr[j] = specular[0]; kg[j] = specular[1]; kb[j] = specular[2];
    er[j] = emission[0]; eg[j] = emission[1]; eb[j] = emission[2];
    const wp::vec3 c = specular;
    o_refl[j] = {LUMA_709_CPP};
    o_ior[j] = ior;
    o_opac[j] = opacity;
    o_rough[j] = roughness;
    out_mid[j] = mid;
}};
for (; xs < x1; xs += CHUNK) {{
    const int n = x1 - xs < CHUNK ? x1 - xs : CHUNK;
    // (a chunk of background pixels alone takes the background's values, nothing else; a
    // chunk that is a whole block (on the CPU) reads and keeps its block's flag: one that
    // holds the background record still is left as it is)
    const bool whole = CHUNK > 1 && xs % CHUNK == 0 && (n == CHUNK || xs + n == cam.width);
    int hits = 0;
    {_RESOLVED_CHUNK_CPP if resolve else "for (int j = 0; j < n; ++j) hits += tris[xs + j] >= 0 ? 1 : 0;"}
    if (hits == 0) {{
        if (whole && blocks[xs / CHUNK] != 0) continue;
        for (int j = 0; j < n; ++j) {{
            {_background_lanes_cpp("false")}
        }}
        {_WRITE_LANES_CPP}{_MISS_RECORD_CPP if resolve else ""}
        if (whole) blocks[xs / CHUNK] = 1;
        continue;
    }}
    if (CHUNK > 1) {{  // (the blocks the chunk overlaps hold a surface from here)
        blocks[xs / CHUNK] = 0;
        blocks[(xs + n - 1) / CHUNK] = 0;
    }}
    // each pixel's material, and whether one of the chunk's samples a texture: where none
    // does, the chunk neither gathers its corners' uvs nor computes their footprint or the
    // surface's uv, which only texture lookups read (a material run by run)
    bool uv_wanted = false;
    for (int j = 0, last = -1; j < n; ++j) {{
        const int tri = tris[xs + j];
        const int mid = tri >= 0 ? scene.triangle_material.data[tri] : -1;
        mids[j] = mid;
        if (mid >= 0 && mid != last) {{
            last = mid;
            const auto& m = scene.materials.data[mid];
            uv_wanted = uv_wanted || {SAMPLES_TEXTURES_CPP};
        }}
    }}
    // (1) the corners: where the chunk's runs of pixels on one triangle are short (small
    // triangles, where a run's own loads and the branches ending it cost more than the
    // loads they save), each pixel's own (``_LOADED_CORNERS_CPP``); else once a run
    int runs = 0;
    for (int j = 0; j < n; ++j) runs += (j == 0 || tris[xs + j] != tris[xs + j - 1]) ? 1 : 0;
    if (runs * {SHORT_RUN_PIXELS} > n) {{
        const float* P = (const float*)corners;
        const float* UV = (const float*)uvs;
        const float* NN = (const float*)corner_normals;
#if defined(__CUDA_ARCH__)
{_GATHERED_CORNERS_CUDA_CPP}
#else
{_LOADED_CORNERS_CPP}
#endif
        {"" if resolve else _BARYCENTRICS_CPP}
    }} else {{
    for (int run = 0; run < n;) {{
        const int tri = tris[xs + run];
        int end = run + 1;
        while (end < n && tris[xs + end] == tri) ++end;
        wp::vec3 a(0.0f), b(0.0f), c(0.0f), na(0.0f), nb(0.0f), nc(0.0f);
        wp::vec2 ta(0.0f), tb(0.0f), tc(0.0f);
        if (tri >= 0) {{
            const int k = 3 * tri;
            a = corners[index[k]];
            b = corners[index[k + 1]];
            c = corners[index[k + 2]];
            if (uv_wanted) {{
                ta = uvs[k];
                tb = uvs[k + 1];
                tc = uvs[k + 2];
            }}
            na = corner_normals[k];
            nb = corner_normals[k + 1];
            nc = corner_normals[k + 2];
        }}
        for (int j = run; j < end; ++j) {{
            {"" if resolve else "const wp::vec2 w = tri >= 0 ? bary[xs + j] : wp::vec2(0.0f); bu[j] = w[0]; bv[j] = w[1];"}
            {_STORE_CORNERS_CPP}
            u0[j] = ta[0]; v0[j] = ta[1]; u1[j] = tb[0]; v1[j] = tb[1]; u2[j] = tc[0]; v2[j] = tc[1];
            mx[j] = na[0]; my[j] = na[1]; mz[j] = na[2];
            nx1[j] = nb[0]; ny1[j] = nb[1]; nz1[j] = nb[2];
            ox[j] = nc[0]; oy[j] = nc[1]; oz[j] = nc[2];
        }}
        run = end;
    }}
    }}
    // (2) across the chunk (``footprint`` a literal: without it the uv footprint folds away)
    auto frames = [&](const bool footprint) WH_INLINE {{
    for (int j = 0; j < n; ++j) {{
        {_LANE_RAY_CPP}{_RESOLVED_HIT_CPP if resolve else ""}
        const wp::vec2 uv0(u0[j], v0[j]);
        const wp::vec2 uv1(u1[j], v1[j]);
        const wp::vec2 uv2(u2[j], v2[j]);
        if (footprint) {{
            {UV_FOOTPRINT_CPP}
            f0[j] = fp[0]; f1[j] = fp[1]; f2[j] = fp[2]; f3[j] = fp[3];
        }} else {{
            f0[j] = 0.0f; f1[j] = 0.0f; f2[j] = 0.0f; f3[j] = 0.0f;
        }}
        wp::vec3 position, ng, nn;
        float u, v;
        bool front;  // (the G-buffer keeps no side)
        wh_surface_frame(p0, p1, p2, wp::vec3(mx[j], my[j], mz[j]), wp::vec3(nx1[j], ny1[j], nz1[j]),
                         wp::vec3(ox[j], oy[j], oz[j]), uv0, uv1, uv2, bu[j], bv[j], d, position, ng, front, u, v,
                         nn, away[j]);
        qx[j] = position[0]; qy[j] = position[1]; qz[j] = position[2];
        gx[j] = ng[0]; gy[j] = ng[1]; gz[j] = ng[2];
        sx[j] = nn[0]; sy[j] = nn[1]; sz[j] = nn[2];
        tu[j] = u; tv[j] = v;
    }}
    }};
    if (uv_wanted) frames(true); else frames(false);
    // (3) the materials, one at a time over the chunk: the level of detail, the taps
    // (where both axes repeat) and the finish vectorised across the chunk for a material
    // whose only texture is its diffuse colour (a patch of one mesh, the common case, takes
    // one such pass; a chunk across a silhouette one per material, the other materials'
    // lanes computed and dropped); any other material's pixels one by one (``wh_material``).
    int chunk_mid = -2;  // -2: no hit yet, -1: more than one material
    for (int j = 0; j < n; ++j) {{
        if (mids[j] >= 0) chunk_mid = chunk_mid == -2 ? mids[j] : (chunk_mid == mids[j] ? chunk_mid : -1);
    }}
    auto across = [&](const int mid) WH_INLINE -> bool {{
        const auto& m = scene.materials.data[mid];
        return m.normal_tex < 0 && (m.flags & {int(FLAG_VERTEX_COLOR)}) == 0 && m.emissive_tex < 0 &&
               m.roughness_tex < 0 && m.metallic_tex < 0 && m.opacity_tex < 0;
    }};
    // material ``mid``'s values kept for its lanes (``keep_material``), computed in every lane
    auto evaluate = [&](const int mid) WH_INLINE {{
        const auto& m = scene.materials.data[mid];
        if (m.diffuse_tex >= 0) {{
            const auto& t = scene.textures.data[m.diffuse_tex];
            for (int j = 0; j < n; ++j) {{
                const wp::vec2 st = wh_texture_uv(t, wp::vec2(tu[j], tv[j]));
                su[j] = st[0]; sv[j] = st[1];
                wh_mip_level(t, wh_lod(t, wp::vec4(f0[j], f1[j], f2[j], f3[j])), level[j], frac[j]);
            }}
            if (t.wrap_s == {int(Wrap.REPEAT)} && t.wrap_t == {int(Wrap.REPEAT)}) {{{_REPEAT_TAPS_CPP}
            }} else {{
                for (int j = 0; j < n; ++j) {{
                    if (mids[j] < 0) continue;
                    const wp::vec4 c = wp::add(wp::cw_mul(wh_trilinear_at(scene.texels.data, t, wp::vec2(su[j], sv[j]),
                                                                          level[j], frac[j]),
                                                          t.scale), t.bias);
                    dr[j] = c[0]; dg[j] = c[1]; db[j] = c[2];
                }}
            }}
        }} else {{
            for (int j = 0; j < n; ++j) {{
                dr[j] = m.diffuse[0]; dg[j] = m.diffuse[1]; db[j] = m.diffuse[2];
            }}
        }}
        for (int j = 0; j < n; ++j) {{
            wp::vec3 albedo, specular;
            float roughness, metallic, opacity;
            wh_material_finish(m, wp::vec3(dr[j], dg[j], db[j]), m.roughness, m.metallic, m.opacity, albedo, specular,
                               roughness, metallic, opacity);
            if (mids[j] == mid) keep_material(j, mid, albedo, specular, m.emissive, roughness, opacity, m.ior);
        }}
    }};
    if (chunk_mid >= 0 && across(chunk_mid)) {{
        evaluate(chunk_mid);
    }} else {{
        // each material that goes across the chunk, from the first lane showing it
        for (int first = 0; first < n; ++first) {{
            const int mid = mids[first];
            if (mid < 0 || (first > 0 && mids[first - 1] == mid)) continue;
            bool seen = false;
            for (int j = 0; j < first; ++j) seen = seen || mids[j] == mid;
            if (!seen && across(mid)) evaluate(mid);
        }}
        for (int j = 0; j < n; ++j) {{
            if (mids[j] < 0 || across(mids[j])) continue;
            const auto& m = scene.materials.data[mids[j]];
            if (m.normal_tex >= 0) {{  // (left for the scalar path, which writes all of it after;
                ++left;                 // until then it takes the background's values, not stale lanes)
                mids[j] = -1;
                continue;
            }}
            wp::vec3 albedo, specular, emission;
            float roughness, metallic, opacity;
            wh_material(scene, m, 3 * tris[xs + j], bu[j], bv[j], wp::vec2(tu[j], tv[j]),
                        wp::vec4(f0[j], f1[j], f2[j], f3[j]), albedo, specular, emission, roughness, metallic, opacity);
            keep_material(j, mids[j], albedo, specular, emission, roughness, opacity, m.ior);
        }}
    }}
    // (4) every channel of the chunk (``_SURFACE_LANES``), the background's values in its
    // background lanes, written out (``wh_write_floats``: in whole lines, past the caches)
    for (int j = 0; j < n; ++j) {{
        const bool hit = mids[j] >= 0;
        const bool flip = hit && away[j];
        sx[j] = flip ? -sx[j] : sx[j];
        sy[j] = flip ? -sy[j] : sy[j];
        sz[j] = flip ? -sz[j] : sz[j];
        {_background_lanes_cpp("hit")}
    }}
    {_WRITE_LANES_CPP}{_HIT_RECORD_WRITE_CPP if resolve else ""}
}}
WH_STREAM_FENCE();
return left;
"""
    )


@wp.func_native(_surface_span_cpp(resolve=False))
def _surface_span(
    scene: SceneGPU,
    cam: CameraGPU,
    gb: GBufferRows,
    background_blocks: wp.array2d(dtype=wp.int32),
    channels: int,
    ddx: wp.vec3,
    ddy: wp.vec3,
    y: int,
    x0: int,
    x1: int,
) -> int:
    """Every channel but the hit record of pixels ``x0 <= x < x1`` of row ``y``
    (``_surface_span_cpp``): pixel by pixel the same bits as ``_write_surface``, the
    background's values (``gbuffer.BACKGROUND``) where no surface is hit (kept where a
    block of ``background_blocks`` says they are there already, and that flag kept);
    the optional channels where ``channels`` has their bit (``SURFACE_EMISSION``...); ``ddx``, ``ddy``:
    the camera ray's steps (``hit_record.sample_steps``).  Returns how many hit pixels
    it left for the scalar path (their material has a normal map)."""
    ...


@wp.func_native(_surface_span_cpp(resolve=True))
def _resolved_surface_span(
    scene: SceneGPU,
    cam: CameraGPU,
    keys: wp.array3d(dtype=wp.uint64),
    gb: GBufferRows,
    background_blocks: wp.array2d(dtype=wp.int32),
    channels: int,
    miss_triangle: int,
    miss_depth: float,
    miss_barycentric: float,
    ddx: wp.vec3,
    ddy: wp.vec3,
    y: int,
    x0: int,
    x1: int,
) -> int:
    """``_surface_span`` over the hit records it resolves from the key slices ``keys``
    first (``_surface_span_cpp``), every channel the hit record's too: pixel by pixel the
    same bits as ``_resolve_span`` then ``_surface_span`` (the background's hit record
    ``miss_triangle``, ``miss_depth``, ``miss_barycentric`` where every slice is empty)."""
    ...


@wp.kernel
def surface_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    keys: wp.array3d(dtype=wp.uint64),
    gb: GBufferRows,
    background_blocks: wp.array2d(dtype=wp.int32),
    channels: int,
    row0: int,
    row_step: int,
    cols: int,
):
    """Per row (a launch item's columns): the surface named by each pixel's hit record
    into the remaining G-buffer channels (the background's values where the pixel sees no
    surface; ``background_blocks``: the G-buffer's ``background_blocks``; the optional
    channels where ``channels`` has their bit, ``SURFACE_EMISSION``...),
    in a native row loop; the pixels it leaves (normal-mapped materials) one at a time.
    The hit record is the one in the G-buffer (whichever primary path wrote it) where
    ``keys`` holds no slice (``_surface_span``); else the raster frame's, resolved from
    the coverage pass's key slices ``keys`` as the row loop reads them and written with
    the other channels (``_resolved_surface_span``)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    first = c * cols
    stop = wp.min(first + cols, cam.width)
    if first < stop:
        steps = sample_steps(cam)
        left = int(0)
        if keys.shape[0] > 0:
            left = _resolved_surface_span(
                scene,
                cam,
                keys,
                gb,
                background_blocks,
                channels,
                wp.static(int(BACKGROUND["triangle_id"])),
                wp.static(float(BACKGROUND["depth"])),
                wp.static(float(BACKGROUND["barycentric"])),
                steps[0],
                steps[1],
                y,
                first,
                stop,
            )
        else:
            left = _surface_span(scene, cam, gb, background_blocks, channels, steps[0], steps[1], y, first, stop)
        if left > 0:
            for x in range(first, stop):
                i = y * cam.width + x
                tri = gb.triangle_id[i]
                if tri >= 0:
                    if scene.materials[scene.triangle_material[tri]].normal_tex >= 0:
                        _write_surface(gb, i, scene, cam, tri, gb.barycentric[i], pixel_ray(cam, x, y), channels)


@wp.kernel
def listed_primary_kernel(
    scene: SceneGPU,
    wide: WideBVHGPU,
    cam: CameraGPU,
    gb: GBufferRows,
    pixels: wp.array(dtype=wp.int32),
    start: int,
    stop: int,
    group: int,
):
    """Per listed pixel of this launch item's group (``parallel.group_launch``): the
    ray-cast hit record (the background's on a miss; ``wide`` as in ``raycast_kernel``)
    and, on a hit, the surface channels; other pixels are untouched."""
    first = start + wp.tid() * group
    for item in range(first, wp.min(first + group, stop)):
        xy = listed_pixel(pixels, item, cam.width, cam.height)
        if xy[0] >= 0:
            i = xy[1] * cam.width + xy[0]
            _write_miss_record(gb, i)
            if scene.mesh != wp.uint64(0):
                _cast(scene, wide, cam, gb, xy[0], xy[1])
            tri = gb.triangle_id[i]
            if tri >= 0:
                _write_surface(
                    gb, i, scene, cam, tri, gb.barycentric[i], pixel_ray(cam, xy[0], xy[1]), wp.static(SURFACE_ALL)
                )
