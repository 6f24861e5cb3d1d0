"""Redrawing only the changed rows and columns (``PostProcess.process(changed_rows=...,
changed_cols=...)``): the same image bit for bit as drawing it whole, FXAA's reach
included, and the whole image wherever the last call's result cannot be kept."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.parallel import Launcher
from warp_hybrid.post.aa import FXAA_REACH_PX, SEARCH_STEP_PX
from warp_hybrid.post.postprocess import PostProcess
from warp_hybrid.timing import StageTimer

H, W = 120, 64
BAND = (60, 63)  # the rows the second frame changes


def _edge_image(jog_row: int) -> np.ndarray:
    """A long vertical edge (dark left, bright right) whose bright side steps one pixel
    left from ``jog_row`` down: FXAA's search along the edge runs until that step."""
    img = np.full((H, W, 3), 0.02, np.float32)
    img[:, 32:] = 0.8
    img[jog_row:, 31] = 0.8
    return img


def _full(device: str, image: np.ndarray, ev: float | None = 0.0, aa: bool = True) -> np.ndarray:
    """``image`` drawn whole by a fresh post stage."""
    with Launcher(device) as launcher:
        color = wp.array(image, dtype=wp.vec3, device=device)
        return PostProcess(launcher).process(color, ev, "aces", aa, StageTimer()).numpy().copy()


def _second_frame(device: str, first: np.ndarray, second: np.ndarray, **kwargs) -> np.ndarray:
    """``first`` drawn whole, then ``second`` (in the same buffer) with ``kwargs``."""
    with Launcher(device) as launcher:
        post = PostProcess(launcher)
        color = wp.array(first, dtype=wp.vec3, device=device)
        post.process(color, kwargs.pop("first_ev", 0.0), "aces", True, StageTimer())
        wp.copy(color, wp.array(second, dtype=wp.vec3, device=device))
        return post.process(color, timer=StageTimer(), tonemap="aces", aa=True, **kwargs).numpy().copy()


def test_reach_is_the_search_length():
    # the last bilinear tap of a full search lies sum(steps) from the centre, and reads
    # the rows half a pixel on either side of it
    assert sum(SEARCH_STEP_PX) == 26.5
    assert FXAA_REACH_PX == 27


def test_changed_rows_redraw_the_same_image(device):
    first, second = _edge_image(jog_row=BAND[0]), _edge_image(jog_row=BAND[1])
    whole = _full(device, second)
    # the step moved within BAND, and FXAA's output changed far along the edge from it
    changed = np.nonzero(np.any(whole != _full(device, first), axis=(1, 2)))[0]
    assert changed.min() < BAND[0] - 10 or changed.max() >= BAND[1] + 10
    assert changed.min() >= BAND[0] - FXAA_REACH_PX and changed.max() < BAND[1] + FXAA_REACH_PX
    partial = _second_frame(device, first, second, exposure_ev=0.0, changed_rows=BAND)
    np.testing.assert_array_equal(partial, whole)


def test_changed_columns_redraw_the_same_image(device):
    # the same edge on its side: a horizontal edge whose step moves along the columns
    first, second = (np.ascontiguousarray(_edge_image(jog_row=j).transpose(1, 0, 2)) for j in BAND)
    whole = _full(device, second)
    changed = np.nonzero(np.any(whole != _full(device, first), axis=(0, 2)))[0]
    assert changed.min() < BAND[0] - 10 or changed.max() >= BAND[1] + 10
    partial = _second_frame(device, first, second, exposure_ev=0.0, changed_rows=(0, W), changed_cols=BAND)
    np.testing.assert_array_equal(partial, whole)
    # a rectangle: the rows around the edge and the band of columns
    partial = _second_frame(device, first, second, exposure_ev=0.0, changed_rows=(28, 36), changed_cols=BAND)
    np.testing.assert_array_equal(partial, whole)


def test_changed_rows_without_aa(device):
    first, second = _edge_image(jog_row=BAND[0]), _edge_image(jog_row=BAND[1])
    with Launcher(device) as launcher:
        post = PostProcess(launcher)
        color = wp.array(first, dtype=wp.vec3, device=device)
        post.process(color, 0.0, "aces", False, StageTimer())
        wp.copy(color, wp.array(second, dtype=wp.vec3, device=device))
        partial = post.process(color, 0.0, "aces", False, StageTimer(), changed_rows=BAND).numpy().copy()
    np.testing.assert_array_equal(partial, _full(device, second, aa=False))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"first_ev": 0.0, "exposure_ev": 1.0},  # another fixed EV
        {"first_ev": None, "exposure_ev": None},  # metered again (keep_exposure False)
        {"first_ev": 0.0, "exposure_ev": None, "keep_exposure": True},  # an EV no call metered
    ],
)
def test_a_changed_exposure_redraws_everything(device, kwargs):
    first = _edge_image(jog_row=BAND[0])
    second = first * 1.5  # changes every row, but the caller claims BAND only
    ev = kwargs["exposure_ev"]
    partial = _second_frame(device, first, second, changed_rows=BAND, **kwargs)
    if kwargs.get("keep_exposure"):
        # switching from a fixed EV to a kept automatic one keeps the fixed one's scale
        np.testing.assert_array_equal(partial, _full(device, second, ev=kwargs["first_ev"]))
    else:
        np.testing.assert_array_equal(partial, _full(device, second, ev=ev))


def test_another_colour_buffer_is_drawn_whole(device):
    first, second = _edge_image(jog_row=BAND[0]), _edge_image(jog_row=BAND[1]) * 0.5
    with Launcher(device) as launcher:
        post = PostProcess(launcher)
        post.process(wp.array(first, dtype=wp.vec3, device=device), 0.0, "aces", True, StageTimer())
        other = wp.array(second, dtype=wp.vec3, device=device)
        partial = post.process(other, 0.0, "aces", True, StageTimer(), changed_rows=BAND).numpy().copy()
    np.testing.assert_array_equal(partial, _full(device, second))
