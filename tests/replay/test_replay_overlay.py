"""The overlay: focus window outline, traced extent and gaze cross at the right pixels."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.replay.overlay import GAZE_ARM_PX, GAZE_COLOUR, TRACED_COLOUR, WINDOW_COLOUR, draw_overlay

BLACK = (0, 0, 0)


def colour_at(image: np.ndarray, column: int, row: int) -> tuple[int, ...]:
    return tuple(int(v) for v in image[row, column])


def test_circle_outline_lands_on_the_nearest_pixels() -> None:
    image = np.zeros((41, 41, 3), np.uint8)
    out = draw_overlay(image, (20.5, 20.5), "circle", 10.0, 10.0, None)
    assert not image.any()  # the input is left alone
    # The circle passes through the centres of pixels (30, 20), (10, 20), (20, 10), (20, 30).
    for column, row in ((30, 20), (10, 20), (20, 10), (20, 30)):
        assert colour_at(out, column, row) == WINDOW_COLOUR
    for column, row in ((32, 20), (31, 20), (29, 20), (20, 20), (8, 20), (20, 32)):
        assert colour_at(out, column, row) == BLACK
    # Every drawn pixel's centre lies within a pixel of the true circle.
    rows, columns = np.nonzero(out.any(axis=2))
    distance = np.hypot(columns + 0.5 - 20.5, rows + 0.5 - 20.5)
    assert np.all(np.abs(distance - 10.0) < 1.0)


def test_rect_outline_and_traced_extent() -> None:
    image = np.zeros((41, 41, 3), np.uint8)
    out = draw_overlay(image, (20.5, 20.5), "rect", 10.0, 6.0, None, traced_radius_px=5.0)
    # Window edges at x = 10.5 and 30.5 (columns 10 and 30), y = 14.5 and 26.5 (rows 14 and 26).
    for column, row in ((10, 20), (30, 20), (20, 14), (20, 26), (10, 14), (30, 26)):
        assert colour_at(out, column, row) == WINDOW_COLOUR
    for column, row in ((9, 20), (31, 20), (20, 13), (20, 27), (11, 20)):
        assert colour_at(out, column, row) == BLACK
    # Traced to half the window: half sizes 5 and 3 (columns 15 and 25, rows 17 and 23).
    for column, row in ((15, 20), (25, 20), (20, 17), (20, 23)):
        assert colour_at(out, column, row) == TRACED_COLOUR
    assert colour_at(out, 14, 20) == BLACK and colour_at(out, 16, 20) == BLACK


def test_traced_circle_only_when_short_of_the_window() -> None:
    image = np.zeros((41, 41, 3), np.uint8)
    out = draw_overlay(image, (20.5, 20.5), "circle", 10.0, 10.0, None, traced_radius_px=6.0)
    assert colour_at(out, 26, 20) == TRACED_COLOUR and colour_at(out, 20, 14) == TRACED_COLOUR
    whole = draw_overlay(image, (20.5, 20.5), "circle", 10.0, 10.0, None, traced_radius_px=10.0)
    assert not (whole == TRACED_COLOUR).all(axis=2).any()


def test_gaze_cross_on_the_pixel_holding_the_gaze() -> None:
    image = np.zeros((41, 41, 3), np.uint8)
    out = draw_overlay(image, (20.5, 20.5), "circle", 3.0, 3.0, (5.7, 35.2))
    drawn = (out == GAZE_COLOUR).all(axis=2)
    rows, columns = np.nonzero(drawn)
    assert set(zip(columns.tolist(), rows.tolist())) == {(5 + d, 35) for d in range(-GAZE_ARM_PX, GAZE_ARM_PX + 1)} | {
        (5, 35 + d) for d in range(-GAZE_ARM_PX, GAZE_ARM_PX + 1)
    }


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="uint8"):
        draw_overlay(np.zeros((4, 4), np.uint8), (2, 2), "circle", 1, 1, None)
    with pytest.raises(ValueError, match="shape"):
        draw_overlay(np.zeros((4, 4, 3), np.uint8), (2, 2), "hexagon", 1, 1, None)
    with pytest.raises(ValueError, match="gaze"):
        draw_overlay(np.zeros((4, 4, 3), np.uint8), (2, 2), "circle", 1, 1, (float("nan"), 1.0))
