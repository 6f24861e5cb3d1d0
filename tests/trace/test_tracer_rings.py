"""``Tracer.trace_rings``: a list of rings traced in bands the threads share, stopped
within one band of a deadline, always a prefix of the list, each pixel as one call over
the whole list traces it; and ``ring_bands``, how the rings are cut."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from test_modes import mirror_scene

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import MIN_BAND_ITEMS, Launcher, band_count
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import Tracer, TraceSettings
from warp_hybrid.trace.tracer import ring_bands

W, H = 64, 48


@pytest.mark.parametrize("ends", [[100], [5, 5, 100, 1000], [0, 0, 3], [1, 2, 3, 4, 5], [4096, 8192]])
@pytest.mark.parametrize("bands", [1, 2, 16])
def test_ring_bands_tile_each_ring_in_order(ends: list[int], bands: int) -> None:
    cut = ring_bands(ends, bands)
    # consecutive, in order, from 0 to the list's end
    assert [b[0] for b in cut] == [0, *np.cumsum([b[1] for b in cut])[:-1].tolist()]
    assert sum(b[1] for b in cut) == ends[-1] and all(b[1] > 0 for b in cut)
    starts = [0, *ends[:-1]]
    for ring, (lo, hi) in enumerate(zip(starts, ends)):
        mine = [b for b in cut if b[2] == ring]
        assert sum(b[1] for b in mine) == hi - lo  # no band crosses a ring's edge
        if hi > lo:
            sizes = [b[1] for b in mine]
            assert max(sizes) - min(sizes) <= 1
            assert len(mine) == max(1, min(hi - lo, math.ceil((hi - lo) * bands / ends[-1])))
        else:
            assert mine == []


class StepClock:
    """Advances ``step`` seconds per reading."""

    def __init__(self, step: float) -> None:
        self.t = 0.0
        self.step = step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


def _traced(device: str, ends: list[int], deadline: float | None, threads: int, clock=None):
    """Trace every pixel of the mirror scene, listed in ``ends``' rings, under ``deadline``."""
    scene = mirror_scene()
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(scene.cameras[0], W, H)
    gb = GBuffer(W, H, device)
    order = np.random.default_rng(7).permutation(W * H).astype(np.int32)
    with Launcher(device, threads=threads) as launcher:
        Rasterizer(launcher).render(ds, cam, gb, StageTimer())
        tracer = Tracer(launcher, TraceSettings())
        color = wp.full((H, W), value=wp.vec3(float("nan")), dtype=wp.vec3, device=device)
        vis = wp.full((H, W, 1), value=float("nan"), dtype=wp.float32, device=device)
        timer = StageTimer() if clock is None else StageTimer(clock=clock)
        pixels = wp.array(order, dtype=wp.int32, device=device)
        done = tracer.trace_rings(ds, cam, gb, pixels, ends, color, vis, timer, deadline=deadline)
        counts = tracer.tally.counts()
    return done, order, color.numpy().reshape(-1, 3), counts, timer.stages_ms


def test_without_a_deadline_every_ring_is_traced_as_one_call_traces_it(device: str) -> None:
    n = W * H
    done, order, color, counts, stages = _traced(device, [n // 4, n // 2, n], None, threads=2)
    whole, _, whole_color, whole_counts, _ = _traced(device, [n], None, threads=1)
    assert done == 3 and whole == 1
    np.testing.assert_array_equal(color, whole_color)
    assert counts == whole_counts and counts.traced_pixels == n
    assert stages["trace_shadow"] > 0.0 and stages["trace_secondary"] > 0.0


@pytest.mark.parametrize("slack", [0.5, 3.5, 6.5, 1e9])
def test_a_deadline_stops_tracing_at_a_prefix_of_the_list(device: str, slack: float) -> None:
    """A clock that ticks 1 s per reading: the first ring always, then bands while the
    clock allows; the pixels traced are exactly the list's first ones, a whole number
    of bands, and the rings counted are those traced whole."""
    n = W * H
    ends = [n // 8, n // 4, n // 2, 3 * n // 4, n]
    clock = StepClock(1.0)
    done, order, color, counts, _ = _traced(device, ends, slack + 1.0, threads=2, clock=clock)
    traced = ~np.isnan(color[:, 0])
    prefix = int(traced[order].sum())
    assert traced[order[:prefix]].all() and not traced[order[prefix:]].any()
    assert counts.traced_pixels == prefix
    assert prefix in {b[0] + b[1] for b in ring_bands(ends, band_count(n, 2, MIN_BAND_ITEMS))}
    assert prefix >= ends[0]
    assert done == sum(1 for e in ends if e <= prefix)
    if slack > 1e6:
        assert done == len(ends)
    if slack == 0.5:  # the deadline passed before the second ring
        assert prefix == ends[0] and done == 1
