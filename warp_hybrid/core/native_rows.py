"""C++ pieces the native row loops share (the post stage's tone map, ``post/kernels.py``,
and FXAA's contrast test, ``post/aa.py``; the raster resolve and the surface pass's
footprints, ``primary/kernels.py``; the lighting pass's direct light,
``lighting/direct_rows.py``): how many pixels a loop takes at a time, a pointer to one
row of an array, and the writer of a chunk's channel in whole cache lines."""

from __future__ import annotations

import numpy as np
import warp as wp

#: Pixels a row loop takes at a time on the CPU (its scratch arrays live on the stack).
CHUNK_CPU = 64

#: The CPU compiler flags of the modules whose row loops gain from 512-bit vectors where the
#: CPU has them (clang prefers 256 bits on Intel server cores): the primary module (the
#: surface pass 10-15% faster, the resolve 5%) and the lighting module (2-5% on the
#: scenes under a dome); the post module's FXAA and tone map do not (FXAA 3-4% slower).
#: Each lane's arithmetic is the same at either width, so are the results.  Warp's own
#: default otherwise (``-march=native``, or ``wp.config.cpu_compiler_flags``).
WIDE_VECTOR_CPU_FLAGS = f"{wp.config.cpu_compiler_flags or '-march=native'} -mprefer-vector-width=512"

#: The CPU compiler flags of a module whose floating-point products and sums fuse into
#: FMAs across statements (as CUDA's compiler fuses them by default), and the macro that
#: tells its C++ so (``wh_lerp_contracted``).
FMA_CONTRACTION_CPU_FLAGS = "-ffp-contract=fast -DWH_FMA_CONTRACTION"

#: Pixels the surface pass's row loop takes at a time on the CPU: its many lane arrays (a
#: chunk's corners, frames, footprints, materials and channels) then stay in the first-level
#: cache.  One thread, against ``CHUNK_CPU``: the surface pass 8-10% faster at 16 or 32;
#: the lighting pass 15-20% slower at 16, the resolve 10% slower at 16 or 128.
SURFACE_CHUNK_CPU = 16


def chunk_cpp(lanes: int = CHUNK_CPU) -> str:
    """C++: the loop's ``CHUNK``, ``lanes`` on the CPU and one on CUDA (where a launch item
    is one pixel)."""
    return f"""
#if defined(__CUDA_ARCH__)
constexpr int CHUNK = 1;
#else
constexpr int CHUNK = {lanes};
#endif
"""


#: ``chunk_cpp`` of ``CHUNK_CPU``, every row loop's but the surface pass's.
CHUNK_CPP = chunk_cpp()

#: C++ every snippet of native lambdas starts with: ``WH_INLINE``, the attribute that forces
#: them inline on the CPU (a literal argument then folds away and a row loop's body is
#: straight-line code), two helpers that keep a loop over lanes vectorisable, and the linear
#: blend every bilinear tap and mip blend uses (with its contraction spelled out too).
LAMBDA_HEADER_CPP = """
#if !defined(WH_INLINE)
#if defined(__CUDA_ARCH__)
#define WH_INLINE
#else
#define WH_INLINE __attribute__((always_inline))
#endif
#endif
// Per component (a select of whole vectors would keep them in memory, unvectorised).
auto wh_select = [&](const bool c, const wp::vec3& a, const wp::vec3& b) WH_INLINE -> wp::vec3 {
    return wp::vec3(c ? a[0] : b[0], c ? a[1] : b[1], c ? a[2] : b[2]);
};
// a (1 - t) + b t of floats or vectors, one Warp operation a call (so nothing is fused).
auto wh_lerp = [&](const auto& a, const auto& b, const float t) WH_INLINE {
    return wp::add(wp::mul(a, wp::sub(1.0f, t)), wp::mul(b, t));
};
// a s + b t of floats as a module's FMA contraction rounds ``wp::add(wp::mul(a, s),
// wp::mul(b, t))``: under ``FMA_CONTRACTION_CPU_FLAGS`` the first product fused into the
// sum, as clang fuses that scalar code, spelled out for loops it vectorises or folds
// otherwise (where it would choose afresh which product to fuse); else as written.
auto wh_add_products = [&](const float a, const float s, const float b, const float t) WH_INLINE -> float {
#if defined(WH_FMA_CONTRACTION) && !defined(__CUDA_ARCH__)
    return __builtin_fmaf(a, s, wp::mul(b, t));
#else
    return wp::add(wp::mul(a, s), wp::mul(b, t));
#endif
};
// ``wh_lerp`` of floats so rounded.
auto wh_lerp_contracted = [&](const float a, const float b, const float t) WH_INLINE -> float {
    return wh_add_products(a, wp::sub(1.0f, t), b, t);
};
// Two consecutive floats ``p[0], p[1]``: on the CPU as one 64-bit load (a loop across lanes
// gathers one 64-bit lane for both, not two 32-bit ones), on CUDA one by one (``p`` need
// not be 8-byte aligned).
auto wh_load2 = [&](const float* p, float& first, float& second) WH_INLINE {
#if defined(__CUDA_ARCH__)
    first = p[0];
    second = p[1];
#else
    unsigned long long bits;
    __builtin_memcpy(&bits, p, sizeof(bits));
    first = __builtin_bit_cast(float, (unsigned int)bits);
    second = __builtin_bit_cast(float, (unsigned int)(bits >> 32));
#endif
};
#if !defined(__CUDA_ARCH__)
// Four floats as one vector register: a texel's channels blended at once, each as
// ``wh_lerp_contracted`` blends a float (the same bits).
typedef float wh_float4 __attribute__((ext_vector_type(4)));
auto wh_load4 = [&](const float* p) WH_INLINE -> wh_float4 {
    wh_float4 v;
    __builtin_memcpy(&v, p, sizeof(v));
    return v;
};
auto wh_lerp4 = [&](const wh_float4 a, const wh_float4 b, const float t) WH_INLINE -> wh_float4 {
    const wh_float4 s = wp::sub(1.0f, t);
    const wh_float4 bt = b * t;
#if defined(WH_FMA_CONTRACTION)
    return __builtin_elementwise_fma(a, s, bt);
#else
    const wh_float4 as = a * s;
    return as + bt;
#endif
};
// The bilinear blend of four texels of ``stride`` floats at ``source`` (texel indices i00,
// i01 in the upper row, i10, i11 in the lower; their first three floats, a fourth loaded
// with them), by weights fx, fy: ``wh_bilinear_blend``'s order of blends.
auto wh_bilinear4 = [&](const float* source, const int stride, const int i00, const int i01, const int i10,
                        const int i11, const float fx, const float fy) WH_INLINE -> wh_float4 {
    return wh_lerp4(wh_lerp4(wh_load4(source + stride * i00), wh_load4(source + stride * i01), fx),
                    wh_lerp4(wh_load4(source + stride * i10), wh_load4(source + stride * i11), fx), fy);
};
// Sixteen lanes' four floats each (``v[0..15]``, one 16-byte load a lane) to lane arrays, in
// registers: the lanes' vectors put together four at a time, then component c of all
// sixteen picked out of those and stored at once into ``out_c[0..15]`` (none where
// ``out_c`` is a literal nullptr): gathering a component across the lanes took a cycle or
// more a lane.
typedef float wh_float8 __attribute__((ext_vector_type(8)));
typedef float wh_float16 __attribute__((ext_vector_type(16)));
#define WH_COMPONENT16(q, c)                                                                                       \
    __builtin_shufflevector(__builtin_shufflevector((q)[0], (q)[1], c, c + 4, c + 8, c + 12, c + 16, c + 20, c + 24, \
                                                    c + 28, c, c + 4, c + 8, c + 12, c + 16, c + 20, c + 24, c + 28), \
                            __builtin_shufflevector((q)[2], (q)[3], c, c + 4, c + 8, c + 12, c + 16, c + 20, c + 24, \
                                                    c + 28, c, c + 4, c + 8, c + 12, c + 16, c + 20, c + 24, c + 28), \
                            0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19, 20, 21, 22, 23)
auto wh_unpack16 = [&](const wh_float4* v, float* out_0, float* out_1, float* out_2, float* out_3) WH_INLINE {
    wh_float16 q[4];
    for (int i = 0; i < 4; ++i) {
        const wh_float8 lo = __builtin_shufflevector(v[4 * i], v[4 * i + 1], 0, 1, 2, 3, 4, 5, 6, 7);
        const wh_float8 hi = __builtin_shufflevector(v[4 * i + 2], v[4 * i + 3], 0, 1, 2, 3, 4, 5, 6, 7);
        q[i] = __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    }
    auto store = [&](float* out, const wh_float16 lanes) WH_INLINE { __builtin_memcpy(out, &lanes, sizeof(lanes)); };
    if (out_0 != nullptr) store(out_0, WH_COMPONENT16(q, 0));
    if (out_1 != nullptr) store(out_1, WH_COMPONENT16(q, 1));
    if (out_2 != nullptr) store(out_2, WH_COMPONENT16(q, 2));
    if (out_3 != nullptr) store(out_3, WH_COMPONENT16(q, 3));
};
#undef WH_COMPONENT16
#endif
// ``wp::normalize``'s arithmetic (a zero vector stays zero).
auto wh_normalize = [&](const wp::vec3& a) WH_INLINE -> wp::vec3 {
    const float l = wp::length(a);
    return wh_select(l > 0.0f, wp::div(a, l), wp::vec3(0.0f));
};
"""


#: C++ (after ``CHUNK_CPP``): ``wh_write_floats(out, k, n, a, b, c, d)`` writes a channel of
#: ``k`` <= 4 float components for a chunk's ``n`` lanes, component q of lane j in
#: ``{a, b, c, d}[q][j]``, interleaved to ``out``; ``wh_write_ints(out, n, a)`` an int channel.
#: Where the chunk is a whole one (``n == CHUNK`` on the CPU) and ``out`` a cache line's
#: start, the values go out in whole lines that bypass the caches (non-temporal stores): a
#: store to part of a line first reads the line, and a pass writing a channel of the whole
#: image (more than the caches hold) spent most of its time in those reads; else one by
#: one.  A row loop that wrote this way ends with ``WH_STREAM_FENCE()`` (the lines ordered
#: before whatever the pass's end publishes to other threads).
STREAM_CPP = """
#if defined(__CUDA_ARCH__)
#define WH_STREAM_LINES(T, out, values, count) (void)0
#define WH_STREAM_FENCE() (void)0
#else
#define WH_STREAM_LINES(T, out, values, count) \\
    for (int wh_i = 0; wh_i < (count); wh_i += 16) { \\
        typedef T wh_line_t __attribute__((ext_vector_type(16))); \\
        __builtin_nontemporal_store(*(const wh_line_t*)((values) + wh_i), (wh_line_t*)((out) + wh_i)); \\
    }
#define WH_STREAM_FENCE() __atomic_thread_fence(__ATOMIC_SEQ_CST)
#endif
auto wh_write_floats = [&](float* out, const int k, const int n, const float* a, const float* b, const float* c,
                           const float* d) WH_INLINE {
    const float* lanes[4] = {a, b, c, d};
    if (CHUNK > 1 && n == CHUNK && ((size_t)out & 63) == 0) {
        alignas(64) float line[4 * CHUNK];
        for (int j = 0; j < CHUNK; ++j)
            for (int q = 0; q < k; ++q) line[k * j + q] = lanes[q][j];
        WH_STREAM_LINES(float, out, line, k * CHUNK);
    } else {
        for (int j = 0; j < n; ++j)
            for (int q = 0; q < k; ++q) out[k * j + q] = lanes[q][j];
    }
};
auto wh_write_ints = [&](int* out, const int n, const int* a) WH_INLINE {
    if (CHUNK > 1 && n == CHUNK && ((size_t)out & 63) == 0) {
        alignas(64) int line[CHUNK];
        for (int j = 0; j < CHUNK; ++j) line[j] = a[j];
        WH_STREAM_LINES(int, out, line, CHUNK);
    } else {
        for (int j = 0; j < n; ++j) out[j] = a[j];
    }
};
"""

#: C++: ``wh_at(a, i, j)``, element (i, j) of a 2-D Warp array (a step of each stride in
#: bytes), for native code that reads arrays through a struct (the tracer's group functions).
WH_AT_CPP = """
auto wh_at = [&](const auto& a, const int i, const int j) WH_INLINE {
    return *(decltype(a.data))((const char*)a.data + (size_t)i * a.strides[0] + (size_t)j * a.strides[1]);
};
"""


def spare_padded(count: int, dtype: type, device: wp.context.Device | str) -> wp.array:
    """``count`` zeroed elements of ``dtype`` on ``device``, a view of an allocation one element
    longer: the row loops load a vec3's three floats as four (``wh_load4``), the last
    element's fourth from the spare one."""
    return wp.zeros(count + 1, dtype=dtype, device=device)[:count]


def float_literal(value: float) -> str:
    """A C++ float32 literal of ``value``: the float32 nearest the double, as Warp rounds its
    constants (``wp::float32(double)``), written exactly in hexadecimal (a decimal with an
    ``f`` would be rounded from the decimal, which can differ next to a halfway case)."""
    return f"{float(np.float32(value)).hex()}f"


def row_cpp(array: str, row: str, ctype: str, const: bool = True) -> str:
    """C++ expression: a pointer to ``ctype`` at the start of row ``row`` of the Warp array
    named ``array`` (a step of its first stride in bytes; the row's own elements must be
    contiguous)."""
    qualifier = "const " if const else ""
    return f"(({qualifier}{ctype}*)(({qualifier}char*){array}.data + (size_t)({row}) * {array}.strides[0]))"
