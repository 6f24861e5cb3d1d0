"""The replay progress bar: silent off a terminal, frames and the within-budget share on one."""

from __future__ import annotations

import pytest

from warp_hybrid.replay.progress import Progress


def test_silent_when_stdout_is_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    with Progress(total=3) as progress:
        for within in (True, False, True):
            progress.update(within)
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    assert not progress.enabled
    assert progress.frames == 3 and progress.frames_within_budget == 2
    assert progress.within_budget_pct == pytest.approx(200.0 / 3.0)


def test_enabled_bar_shows_frames_rate_and_budget_share(capsys: pytest.CaptureFixture[str]) -> None:
    with Progress(total=3, enabled=True) as progress:
        for within in (True, False, True):
            progress.update(within)
    out = capsys.readouterr().out
    assert "3/3" in out
    assert "frame/s" in out
    assert "within budget 67%" in out


def test_unknown_total(capsys: pytest.CaptureFixture[str]) -> None:
    progress = Progress(total=None, enabled=True)
    progress.update(False)
    progress.close()
    progress.close()
    out = capsys.readouterr().out
    assert "1frame" in out.replace(" ", "") and "within budget 0%" in out
    assert Progress(total=None).within_budget_pct is None
