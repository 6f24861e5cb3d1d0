"""StageTimer with an injected clock: exact, deterministic stage times."""

from __future__ import annotations

import pytest

from warp_hybrid.timing import StageTimer


class FakeClock:
    """A clock that advances only when told to."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_stages_accumulate_with_injected_clock() -> None:
    clock = FakeClock()
    syncs = []
    timer = StageTimer(clock=clock, sync=lambda: syncs.append(1))
    with timer.stage("raster"):
        clock.now += 0.004
    with timer.stage("lighting"):
        clock.now += 0.0015
    with timer.stage("raster"):
        clock.now += 0.001
    assert timer.stages_ms == pytest.approx({"raster": 5.0, "lighting": 1.5}, abs=1e-9)
    assert timer.total_ms == pytest.approx(6.5, abs=1e-9)
    assert len(syncs) == 6  # synchronised before every reading


def test_stage_time_recorded_when_block_raises() -> None:
    clock = FakeClock()
    timer = StageTimer(clock=clock)
    try:
        with timer.stage("trace"):
            clock.now += 0.002
            raise RuntimeError("boom")
    except RuntimeError:
        pass
    assert timer.stages_ms == pytest.approx({"trace": 2.0}, abs=1e-9)
