"""The launch layer covers every pixel/item exactly once, whatever the thread count."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.parallel import Launcher


@wp.kernel
def _count_pixels(
    out: wp.array2d(dtype=wp.int32), item_cols: wp.array2d(dtype=wp.int32), row0: int, row_step: int, cols: int
):
    """Count the visits of each pixel; record the ``cols`` of the item that visited it."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, out.shape[1])):
        out[y, x] = out[y, x] + 1
        item_cols[y, x] = cols


@wp.kernel
def _count_items(out: wp.array(dtype=wp.int32), start: int, step: int):
    i = start + wp.tid() * step
    out[i] = out[i] + 1


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize(("height", "width"), [(1, 1), (2, 5), (7, 3), (48, 33)])
def test_launch_pixels_covers_each_pixel_once(device: str, threads: int, height: int, width: int) -> None:
    out = wp.zeros((height, width), dtype=wp.int32, device=device)
    item_cols = wp.zeros((height, width), dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_pixels(_count_pixels, height, width, [out, item_cols])
    np.testing.assert_array_equal(out.numpy(), np.ones((height, width), np.int32))
    # the device's shape: a whole row per launch item on the CPU, one pixel on CUDA
    expected_cols = 1 if wp.get_device(device).is_cuda else width
    np.testing.assert_array_equal(item_cols.numpy(), np.full((height, width), expected_cols, np.int32))


def test_launch_pixels_skips_empty_images(device: str) -> None:
    out = wp.zeros((1, 1), dtype=wp.int32, device=device)
    with Launcher(device, 2) as launcher:
        launcher.launch_pixels(_count_pixels, 0, 1, [out, out])
        launcher.launch_pixels(_count_pixels, 1, 0, [out, out])
    assert out.numpy()[0, 0] == 0


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


def test_a_launch_profile_times_every_piece_by_kernel(device: str) -> None:
    """Attached, the profile counts each launch once and times each of its pieces (one
    per thread) under the kernel's name, and ``run`` pieces under theirs; detached, it
    records nothing more."""
    from warp_hybrid.launch_profile import LaunchProfile

    out = wp.zeros((64, 32), dtype=wp.int32, device=device)
    cols = wp.zeros((64, 32), dtype=wp.int32, device=device)
    items = wp.zeros(100, dtype=wp.int32, device=device)

    def busy(k: int, n: int) -> int:
        return sum(range(20000 * (k + 1)))

    with Launcher(device, 2) as launcher:
        profile = LaunchProfile()
        launcher.profile = profile
        for _ in range(3):
            launcher.launch_pixels(_count_pixels, 64, 32, [out, cols])
        launcher.launch_items(_count_items, 100, [items])
        assert launcher.run(busy) == [sum(range(20000)), sum(range(40000))]
        launcher.profile = None
        launcher.launch_items(_count_items, 100, [items])
    pieces = {0} if wp.get_device(device).is_cuda else {0, 1}
    pixels, listed = profile.kernels[_count_pixels.key], profile.kernels[_count_items.key]
    assert (pixels.launches, listed.launches) == (3, 1)
    assert set(pixels.piece_ms) == pieces and set(listed.piece_ms) == {0, 1}
    run = profile.kernels["test_a_launch_profile_times_every_piece_by_kernel.<locals>.busy"]
    assert run.launches == 1 and run.piece_ms[1] > 0.0 and run.cpu_ms > 0.0
    assert 0.0 < run.balance <= 1.0
    rows = profile.rows(frames=1)
    assert [r["kernel"] for r in rows] == sorted(
        profile.kernels, key=lambda n: -max(profile.kernels[n].piece_ms.values())
    )
    assert all(r["cpu_ms"] >= 0.0 for r in rows)
    np.testing.assert_array_equal(items.numpy(), np.full(100, 2, np.int32))
