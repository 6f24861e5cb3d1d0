"""The ray tally by screen tile against a numpy count: lists in any order, entries off the
screen skipped, any thread count."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.parallel import Launcher
from warp_hybrid.trace.tally import TALLY_COLUMNS, TILE_PX, RayTally, tally_tiles


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("order", ["rows", "shuffled"])
def test_tiles_count_every_listed_pixel_and_its_rays(device: str, threads: int, order: str) -> None:
    width, height = 100, 70  # tiles of 32: 4 x 3, the last column and row partial
    rng = np.random.default_rng(3)
    pixels = np.concatenate([np.arange(0, width * height, 3), [-1, width * height, 2**31 - 1, -(2**31)]])
    if order == "shuffled":
        rng.shuffle(pixels)
    counts = rng.integers(0, 5, (len(pixels), 4)).astype(np.int32)
    with Launcher(device, threads) as launcher:
        tally = RayTally(width, height, launcher.threads, launcher.device)
        launcher.launch_slots(
            tally_tiles,
            len(pixels),
            [
                wp.array(pixels.astype(np.int32), device=device),
                wp.array(counts, device=device),
                width,
                height,
                tally.tiles_x,
                tally.table,
            ],
            min_band_items=64,
        )
        tiles = tally.tiles()
    on = (pixels >= 0) & (pixels < width * height)
    y, x = np.divmod(pixels[on], width)
    tile = (y // TILE_PX) * tally.tiles_x + x // TILE_PX
    expected = np.zeros((tally.tiles_y * tally.tiles_x, len(TALLY_COLUMNS)), np.int64)
    np.add.at(expected[:, 0], tile, 1)
    np.add.at(expected[:, 1], tile, counts[on, 0] + counts[on, 1])
    np.add.at(expected[:, 2], tile, counts[on, 2])
    np.add.at(expected[:, 3], tile, counts[on, 3])
    expected = expected.reshape(tally.tiles_y, tally.tiles_x, -1)
    np.testing.assert_array_equal(tiles.pixels, expected[..., 0])
    np.testing.assert_array_equal(tiles.rays, expected[..., 1:])
    assert tiles.pixels.sum() == on.sum() and tiles.pixels[-1, -1] > 0
