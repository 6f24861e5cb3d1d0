"""The representable range (``scene.local_frame.frame_problem``) on the points' side."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.scene.local_frame import MAX_LOCAL_COORDINATE, frame_problem

LIMIT = MAX_LOCAL_COORDINATE
ORIGIN = np.zeros(3)


def points(*rows: tuple[float, float, float]) -> np.ndarray:
    """A float32 (N, 3) point array, within the range but for the given rows."""
    p = np.tile(np.float32([1.0, -2.0, 3.0]), (8, 1))
    for i, row in enumerate(rows):
        p[2 * i + 1] = row
    return p


@pytest.mark.parametrize("row", [(LIMIT, 0.0, 0.0), (0.0, -LIMIT, 0.0), (0.0, 0.0, LIMIT)])
def test_a_coordinate_at_the_limit_is_within_the_range(row) -> None:
    assert frame_problem(points(row), [], [], ORIGIN) is None


@pytest.mark.parametrize("row", [(3.0 * LIMIT, 0.0, 0.0), (0.0, -3.0 * LIMIT, 0.0), (0.0, 0.0, 2.5 * LIMIT)])
def test_the_first_point_beyond_the_range_is_named(row) -> None:
    found = frame_problem(points((0.0, 0.0, 0.0), row, row), [], [], ORIGIN)
    assert found is not None
    problem, at = found
    assert at == 3 and problem.startswith("point 3 (") and "beyond the representable range" in problem


def test_a_nan_elsewhere_does_not_hide_a_point_beyond_the_range() -> None:
    found = frame_problem(points((np.nan, 0.0, 0.0), (0.0, 4.0 * LIMIT, 0.0)), [], [], ORIGIN)
    assert found is not None and found[1] == 3
    assert frame_problem(points((np.nan, 0.0, 0.0)), [], [], ORIGIN) is None  # finiteness is checked elsewhere
