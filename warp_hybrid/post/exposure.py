"""Exposure: a fixed EV or automatic exposure from the log-average luminance.

The exposed colour is ``color * 2**ev``.  Automatic exposure (Reinhard et al. 2002,
"key value") picks ``ev = log2(key / Lavg)`` with ``Lavg = exp(mean(log(delta + Y)))``
over the hit pixels (Y the Rec. 709 luminance of the linear colour, ``delta`` keeps
black pixels finite), so the log-average lands on middle grey, ``key = 0.18``.

The output stage never reads the exposure back during a frame: it sums the logs on
the device per row (``kernels.LOG_LUMINANCE_KERNELS``, float64; on the CPU the lighting
row loop sums them as it writes the raster layer, ``core.passes.MeteredRows``, from the
same text, ``LOG_LUMINANCE_CPP`` and the two after it), then one device thread sums
the rows (``pairwise_sum``, numpy's summation order) and applies
``exposure_from_log_sum`` into an ``Exposure`` record that the tone map reads.  The
tests compare it with a numpy reference (``tests/post/exposure_reference.py``); both
take ``KEY_VALUE``, ``LOG_DELTA`` and ``EV_LIMIT`` from here.
"""

from __future__ import annotations

import warp as wp

from ..core.constants import LUMA_709_CPP
from ..core.native_rows import float_literal

KEY_VALUE = 0.18
LOG_DELTA = 1.0e-4
EV_LIMIT = 24.0
FLOAT_MAX = 3.4028234663852886e38

#: C++ (a lambda, before ``LOG_TERM_CPP``): ``wh_log_float(x)``, the natural log of a
#: positive normal float in double precision, relative error under 2.3e-16, so that rounded
#: to float it is the correctly rounded ``logf`` (checked against the double ``log`` for
#: every positive normal float; glibc's ``logf``, within 0.82 ulp, rounds 3 in 10000 of
#: them the other way).  ``x = 2^e m`` with ``m`` in [sqrt(1/2), sqrt(2)); ``ln m = 2
#: atanh(s)``, ``s = (m - 1) / (m + 1)``, ``|s| < 0.172``, by its odd series to ``s^21``.
#: Plain arithmetic, no table and no library call, so a loop of it vectorises, and every
#: product and sum rounded as written (explicit FMAs, nothing left for a compiler to
#: contract), so it gives the same bits in every module and on every device.
LOG_FLOAT_CPP = """
auto wh_log_float = [&](const float x) WH_INLINE -> double {
#if defined(__CUDA_ARCH__)
    auto fused = [](const double a, const double b, const double c) { return fma(a, b, c); };
#else
    auto fused = [](const double a, const double b, const double c) { return __builtin_fma(a, b, c); };
#endif
    union { float f; unsigned int u; } bits;
    bits.f = x;
    const int e = ((int)(bits.u - 0x3f3504f3u)) >> 23;  // (0x3f3504f3: sqrt(1/2))
    bits.u -= (unsigned int)e << 23;
    const double f = (double)bits.f - 1.0;
    const double s = f / (2.0 + f);
    const double z = s * s;
    double p = 1.0 / 21.0;
    p = fused(p, z, 1.0 / 19.0);
    p = fused(p, z, 1.0 / 17.0);
    p = fused(p, z, 1.0 / 15.0);
    p = fused(p, z, 1.0 / 13.0);
    p = fused(p, z, 1.0 / 11.0);
    p = fused(p, z, 1.0 / 9.0);
    p = fused(p, z, 1.0 / 7.0);
    p = fused(p, z, 1.0 / 5.0);
    p = fused(p, z, 1.0 / 3.0);
    const double two_s = 2.0 * s;
    return fused((double)e, 0x1.62e42fefa39efp-1, fused(two_s * z, p, two_s));  // e ln 2 + ln m
};
"""

#: C++ of what a metered pixel adds, given its colour ``c`` (a ``wp::vec3``): ``l`` its
#: Rec. 709 luminance, ``LOG_COUNTS_CPP`` whether it counts (finite), ``LOG_TERM_CPP`` its
#: float64 term ``log(delta + max(l, 0))``, the log rounded to float (``wh_log_float``,
#: ``LOG_FLOAT_CPP``; any ``l`` gives a value, used only where it counts): one text for
#: every metering (the post stage's pass and the lighting row loop's,
#: ``lighting.direct_rows``), so their sums agree.
LOG_LUMINANCE_CPP = f"const float l = {LUMA_709_CPP};"
LOG_COUNTS_CPP = f"wp::abs(l) <= {float_literal(FLOAT_MAX)}"
LOG_TERM_CPP = f"(double)(float)wh_log_float(wp::add({float_literal(LOG_DELTA)}, wp::max(l, 0.0f)))"

_KEY_VALUE_F64 = wp.constant(wp.float64(KEY_VALUE))
_EV_LIMIT_F64 = wp.constant(wp.float64(EV_LIMIT))
#: numpy's pairwise summation: blocks of at most this many values are summed directly.
_PAIRWISE_BLOCK = wp.constant(128)
_vec8d = wp.types.vector(length=8, dtype=wp.float64)
_vec32d = wp.types.vector(length=32, dtype=wp.float64)
_vec32i = wp.types.vector(length=32, dtype=wp.int32)


@wp.struct
class Exposure:
    """A frame's exposure in device memory (a 1-element array): the EV and the scale
    ``2**ev`` (float32, as the tone map multiplies by it)."""

    ev: wp.float64
    scale: wp.float32


@wp.func
def _block_sum(a: wp.array(dtype=wp.float64), start: int, n: int) -> wp.float64:
    """numpy's sum of a block of ``n <= _PAIRWISE_BLOCK`` values from ``a[start]``: in
    order below 8 values, else 8 interleaved accumulators combined as a tree, then
    the remainder in order."""
    if n < 8:
        total = wp.float64(0.0)
        for i in range(n):
            total += a[start + i]
        return total
    acc = _vec8d()
    for j in range(8):
        acc[j] = a[start + j]
    i = int(8)
    while i < n - n % 8:
        for j in range(8):
            acc[j] += a[start + i + j]
        i += 8
    total = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
    while i < n:
        total += a[start + i]
        i += 1
    return total


@wp.func
def pairwise_sum(a: wp.array(dtype=wp.float64)) -> wp.float64:
    """The sum of ``a`` in numpy's order (``np.sum``'s pairwise summation: halves
    rounded down to a multiple of 8, blocks of at most 128 by ``_block_sum``), so one
    device thread reproduces the host's float64 sum bit for bit.

    The recursion runs on an explicit stack: per level, the right half still to sum
    and, once done, the left half's sum (32 levels cover any int32 length)."""
    left_sum = _vec32d()
    left_done = _vec32i()
    right_start = _vec32i()
    right_n = _vec32i()
    depth = int(0)
    start = int(0)
    n = a.shape[0]
    while True:
        while n > _PAIRWISE_BLOCK:  # descend into the left half
            half = n // 2
            half -= half % 8
            right_start[depth] = start + half
            right_n[depth] = n - half
            left_done[depth] = 0
            depth += 1
            n = half
        total = _block_sum(a, start, n)
        while depth > 0 and left_done[depth - 1] != 0:  # a right half: add it to its left
            depth -= 1
            total = left_sum[depth] + total
        if depth == 0:
            return total
        left_sum[depth - 1] = total  # a left half: now sum its right half
        left_done[depth - 1] = 1
        start = right_start[depth - 1]
        n = right_n[depth - 1]
    return wp.float64(0.0)


@wp.func
def exposure_from_log_sum(log_sum: wp.float64, count: wp.int64, two: wp.float64) -> Exposure:
    """The EV that maps ``exp(log_sum / count)`` to ``KEY_VALUE`` (0 when ``count`` is 0,
    clamped to +-``EV_LIMIT``), on the device, with its scale.

    ``two`` must be 2.0, passed in at run time: with a literal base the compiler
    rewrites ``pow(2, ev)`` to ``exp2(ev)``, which differs from the host's
    ``2.0 ** ev`` in the last bit for about one EV in a thousand."""
    exposure = Exposure()
    exposure.ev = wp.float64(0.0)
    if count > wp.int64(0):
        lavg = wp.exp(log_sum / wp.float64(count))
        if lavg > wp.float64(0.0):
            exposure.ev = wp.clamp(wp.log2(_KEY_VALUE_F64 / lavg), -_EV_LIMIT_F64, _EV_LIMIT_F64)
    exposure.scale = wp.float32(wp.pow(two, exposure.ev))
    return exposure
