"""Host references for the automatic exposure (numpy): what the device computes,
written the plain way, for the tests to compare against."""

from __future__ import annotations

import math

import numpy as np

from warp_hybrid.core.constants import LUMA_709
from warp_hybrid.post.exposure import EV_LIMIT, KEY_VALUE, LOG_DELTA


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
