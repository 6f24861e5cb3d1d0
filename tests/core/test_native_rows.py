"""The row loops' channel writes (``native_rows.STREAM_CPP``): every lane's components land
interleaved at their place, whether the chunk goes out in whole cache lines (a whole chunk
at a line's start) or value by value (a chunk at another offset, a partial chunk), and
nothing outside the chunk is touched."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.native_rows import CHUNK_CPP, CHUNK_CPU, LAMBDA_HEADER_CPP, STREAM_CPP

wp.set_module_options({"enable_backward": False})

_WRITE_CPP = (
    CHUNK_CPP
    + LAMBDA_HEADER_CPP
    + STREAM_CPP
    + """
float a[CHUNK], b[CHUNK], c[CHUNK], d[CHUNK];
int ids[CHUNK];
for (int j = 0; j < n; ++j) {
    a[j] = 1000.0f * (float)j;
    b[j] = a[j] + 1.0f;
    c[j] = a[j] + 2.0f;
    d[j] = a[j] + 3.0f;
    ids[j] = 7 * j + 5;
}
const float* lanes[4] = {a, b, c, d};
wh_write_floats(floats.data + offset, k, n, lanes[0], k > 1 ? lanes[1] : nullptr, k > 2 ? lanes[2] : nullptr,
                k > 3 ? lanes[3] : nullptr);
wh_write_ints(ints.data + offset, n, ids);
WH_STREAM_FENCE();
"""
)


@wp.func_native(_WRITE_CPP)
def _write_chunk(floats: wp.array(dtype=wp.float32), ints: wp.array(dtype=wp.int32), k: int, n: int, offset: int):
    """Lane j's components 1000 j + q (q < k) from ``floats[offset]`` on, its id 7 j + 5 at
    ``ints[offset + j]``, for ``n`` lanes."""
    ...


@wp.kernel
def _write_kernel(floats: wp.array(dtype=wp.float32), ints: wp.array(dtype=wp.int32), k: int, n: int, offset: int):
    _write_chunk(floats, ints, k, n, offset)


@pytest.mark.parametrize("k", [1, 2, 3, 4])
@pytest.mark.parametrize(
    ("n", "offset"),
    [(CHUNK_CPU, 0), (CHUNK_CPU, 16), (CHUNK_CPU, 3), (CHUNK_CPU - 5, 0)],
    ids=["whole-lines", "whole-at-a-later-line", "misaligned", "partial"],
)
def test_lanes_land_interleaved_and_nothing_else_moves(k, n, offset):
    size = 4 * CHUNK_CPU + 64
    floats = wp.full(size, -1.0, dtype=wp.float32, device="cpu")
    ints = wp.full(size, -1, dtype=wp.int32, device="cpu")
    assert floats.ptr % 64 == 0 and ints.ptr % 64 == 0  # (offset 0 is a line's start)
    wp.launch(_write_kernel, dim=1, inputs=[floats, ints, k, n, offset], device="cpu")
    got_f, got_i = floats.numpy(), ints.numpy()
    lanes = np.arange(n)
    want = (1000.0 * lanes[:, None] + np.arange(k)[None, :]).astype(np.float32).ravel()
    np.testing.assert_array_equal(got_f[offset : offset + k * n], want)
    assert (got_f[:offset] == -1.0).all() and (got_f[offset + k * n :] == -1.0).all()
    np.testing.assert_array_equal(got_i[offset : offset + n], 7 * lanes + 5)
    assert (got_i[:offset] == -1).all() and (got_i[offset + n :] == -1).all()
