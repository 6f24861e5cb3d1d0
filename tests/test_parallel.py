"""The launch layer covers every row/item exactly once, whatever the thread count."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.parallel import Launcher


@wp.kernel
def _count_rows(out: wp.array2d(dtype=wp.int32), row0: int, row_step: int):
    r, x = wp.tid()
    y = row0 + r * row_step
    out[y, x] = out[y, x] + 1 + y * 0


@wp.kernel
def _count_items(out: wp.array(dtype=wp.int32), start: int, step: int):
    i = start + wp.tid() * step
    out[i] = out[i] + 1


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("height", [1, 2, 7, 48])
def test_launch_rows_covers_each_pixel_once(device: str, threads: int, height: int) -> None:
    out = wp.zeros((height, 5), dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_rows(_count_rows, height, 5, [out])
    np.testing.assert_array_equal(out.numpy(), np.ones((height, 5), np.int32))


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("count", [1, 5, 100])
def test_launch_items_covers_each_item_once(device: str, threads: int, count: int) -> None:
    out = wp.zeros(count, dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_items(_count_items, count, [out])
    np.testing.assert_array_equal(out.numpy(), np.ones(count, np.int32))


def test_run_propagates_exceptions(device: str) -> None:
    def piece(k: int, n: int) -> int:
        if k == 1:
            raise ValueError("piece 1 failed")
        return k

    with Launcher(device, 2) as launcher:
        with pytest.raises(ValueError, match="piece 1 failed"):
            launcher.run(piece)
        assert launcher.run(lambda k, n: (k, n)) == [(0, 2), (1, 2)]
