"""Exposure: a fixed EV or automatic exposure from the log-average luminance.

The exposed colour is ``color * 2**ev``.  Automatic exposure (Reinhard et al. 2002,
"key value") picks ``ev = log2(key / Lavg)`` with ``Lavg = exp(mean(log(delta + Y)))``
over the hit pixels (Y the Rec. 709 luminance of the linear colour, ``delta`` keeps
black pixels finite), so the log-average lands on middle grey, ``key = 0.18``.

The output stage never reads the exposure back during a frame: it sums the logs on
the device per row (``kernels.LOG_LUMINANCE_KERNELS``, float64), then one device
thread sums the rows (``pairwise_sum``, numpy's summation order) and applies
``exposure_from_log_sum``, the device twin of ``ev_from_log_sum``, into an
``Exposure`` record that the tone map reads.  The host functions here compute the
same from numpy arrays (the reference the tests compare against); both sides take
``KEY_VALUE``, ``LOG_DELTA`` and ``EV_LIMIT`` from here.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..core.constants import LUMA_709

KEY_VALUE = 0.18
LOG_DELTA = 1.0e-4
EV_LIMIT = 24.0

_KEY_VALUE_F64 = wp.constant(wp.float64(KEY_VALUE))
_EV_LIMIT_F64 = wp.constant(wp.float64(EV_LIMIT))
#: numpy's pairwise summation: blocks of at most this many values are summed directly.
_PAIRWISE_BLOCK = wp.constant(128)
_vec8d = wp.types.vector(length=8, dtype=wp.float64)
_vec32d = wp.types.vector(length=32, dtype=wp.float64)
_vec32i = wp.types.vector(length=32, dtype=wp.int32)


def log_average_luminance(color: np.ndarray, mask: np.ndarray | None = None) -> float | None:
    """``exp(mean(log(delta + Y)))`` over the finite pixels selected by ``mask``
    ((H, W) bool, None = every pixel with Y > 0); None when no pixel qualifies."""
    c = np.asarray(color, dtype=np.float32)
    y = c[..., 0] * np.float32(LUMA_709[0]) + c[..., 1] * np.float32(LUMA_709[1]) + c[..., 2] * np.float32(LUMA_709[2])
    select = np.isfinite(y)
    select &= mask.astype(bool) if mask is not None else y > 0.0
    if not select.any():
        return None
    logs = np.log(np.float32(LOG_DELTA) + np.maximum(y[select], np.float32(0.0)))
    return float(np.exp(np.mean(logs, dtype=np.float64)))


def ev_from_log_average(lavg: float | None, key: float = KEY_VALUE) -> float:
    """The EV that maps the log-average luminance ``lavg`` to ``key``; 0 for None (no
    pixel qualified).  Clamped to +-24 stops."""
    if lavg is None or lavg <= 0.0:
        return 0.0
    return float(np.clip(math.log2(key / lavg), -EV_LIMIT, EV_LIMIT))


def ev_from_log_sum(log_sum: float, count: int, key: float = KEY_VALUE) -> float:
    """``ev_from_log_average`` from the sum and the number of the pixels' logs."""
    return ev_from_log_average(math.exp(log_sum / count) if count > 0 else None, key)


def auto_exposure_ev(color: np.ndarray, mask: np.ndarray | None = None, key: float = KEY_VALUE) -> float:
    """The EV that maps the log-average luminance of ``color`` (H, W, 3, linear) to
    ``key``; 0 when no pixel qualifies.  Clamped to +-24 stops."""
    return ev_from_log_average(log_average_luminance(color, mask), key)


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
    """``ev_from_log_sum`` (key ``KEY_VALUE``) on the device, with its scale.

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
