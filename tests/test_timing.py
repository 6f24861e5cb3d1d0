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


def test_a_charge_moves_time_from_the_open_stage_to_the_one_that_started_the_work() -> None:
    """A wait inside "lighting" for work "surface" started is "surface"'s time: the stages
    still add up to the clock's time; outside every stage a charge only adds."""
    clock = FakeClock()
    timer = StageTimer(clock=clock)
    assert timer.current is None
    with timer.stage("surface"):
        assert timer.current == "surface"
        clock.now += 0.001
    with timer.stage("lighting"):
        assert timer.current == "lighting"
        clock.now += 0.003
        timer.charge("surface", 0.002)
    assert timer.current is None
    assert timer.stages_ms == pytest.approx({"surface": 3.0, "lighting": 1.0}, abs=1e-9)
    assert timer.total_ms == pytest.approx(4.0, abs=1e-9)
    timer.charge("aa", 0.0005)
    assert timer.stages_ms["aa"] == pytest.approx(0.5, abs=1e-9)


def test_a_charge_in_a_nested_stage_leaves_the_enclosing_ones_too() -> None:
    clock = FakeClock()
    timer = StageTimer(clock=clock)
    with timer.stage("alpha_layer"):
        clock.now += 0.001
        with timer.stage("lighting"):
            clock.now += 0.004
            timer.charge("surface", 0.003)
        clock.now += 0.002
    assert timer.stages_ms == pytest.approx({"lighting": 1.0, "surface": 3.0, "alpha_layer": 4.0}, abs=1e-9)
