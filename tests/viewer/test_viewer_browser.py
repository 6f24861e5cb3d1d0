"""End to end in a real headless browser: Debian's chromium driven by Playwright (nothing downloaded).

The page loads, the mouse moves over the frame, the focus window follows it, frames
arrive and the HUD shows the pointer-to-frame latency; the screenshot goes to
``build/viewer-e2e.png`` (and to ``docs/viewer.png`` with ``WARP_HYBRID_UPDATE_DOCS=1``).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import ROOT, STILL, started, view_settings
from serverthread import ServerThread

CHROMIUM = next((p for p in (shutil.which("chromium"), "/usr/bin/chromium") if p and Path(p).is_file()), None)
if CHROMIUM is None:
    pytest.skip("Debian's chromium is not installed (apt-get install -y chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright for Python is not installed")

SIZE = (128, 96)
SCREENSHOT = ROOT / "build" / "viewer-e2e.png"
DOCS_SCREENSHOT = ROOT / "docs" / "viewer.png"
WAIT_MS = 120_000


@pytest.fixture(scope="module")
def url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The showcase scene served on a loopback port."""
    settings = view_settings(tmp_path_factory.mktemp("browser"))
    settings.render.width, settings.render.height = SIZE
    viewer = started(STILL, settings)
    try:
        with ServerThread(viewer) as server:
            yield server.url
    finally:
        viewer.thread.stop()


def _frame_point(page, x: float, y: float) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """Page coordinates of normalised (x, y) on the letterboxed frame."""
    box = page.locator("#frame").bounding_box()
    scale = min(box["width"] / SIZE[0], box["height"] / SIZE[1])
    w, h = SIZE[0] * scale, SIZE[1] * scale
    return box["x"] + (box["width"] - w) / 2 + x * w, box["y"] + (box["height"] - h) / 2 + y * h


def test_the_focus_window_follows_the_mouse_and_frames_arrive(url: str) -> None:
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True)
        try:
            page = browser.new_page(viewport={"width": 1000, "height": 560})
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.on("requestfailed", lambda req: errors.append(f"request failed: {req.url}"))
            page.goto(url)
            page.wait_for_function("() => window.viewerState.frames > 2", timeout=WAIT_MS)
            assert page.locator("#shortcuts tr").count() >= 10
            assert page.locator("#protocol code").count() >= 9
            for x, y in ((0.8, 0.3), (0.2, 0.7)):
                page.mouse.move(*_frame_point(page, x, y), steps=4)
                page.wait_for_function(
                    f"""() => {{
                        const h = window.viewerState.header;
                        return h && h.pointer && h.pointer.client === window.viewerState.client
                            && Math.abs(h.gaze.x - {x}) < 0.03 && Math.abs(h.gaze.y - {y}) < 0.03;
                    }}""",
                    timeout=WAIT_MS,
                )
                header = page.evaluate("() => window.viewerState.header")
                cx, cy = header["window"]["centre"]
                assert (cx > SIZE[0] / 2) == (x > 0.5) and (cy > SIZE[1] / 2) == (y > 0.5)
            frames = page.evaluate("() => window.viewerState.frames")
            page.wait_for_function("n => window.viewerState.frames > n", arg=frames + 3, timeout=WAIT_MS)
            latency = page.evaluate("() => window.viewerState.latencyMs")
            assert latency is not None and 0.0 < latency < 60_000
            assert page.locator("#hud-latency").inner_text() not in ("", "–")
            assert float(page.locator("#hud-frame-ms").inner_text()) > 0.0
            page.keyboard.press("w")
            page.wait_for_function("() => window.viewerState.header.state.shape === 'rect'", timeout=WAIT_MS)
            page.keyboard.press("w")
            page.wait_for_function("() => window.viewerState.header.state.shape === 'circle'", timeout=WAIT_MS)
            page.mouse.move(*_frame_point(page, 0.62, 0.45), steps=2)
            page.wait_for_function("() => Math.abs(window.viewerState.header.gaze.x - 0.62) < 0.03", timeout=WAIT_MS)
            page.wait_for_timeout(500)
            SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(SCREENSHOT))
            if os.environ.get("WARP_HYBRID_UPDATE_DOCS") == "1":
                page.screenshot(path=str(DOCS_SCREENSHOT))
            page.keyboard.press("o")
            assert page.evaluate("() => window.viewerState.overlay") is False
            assert errors == [] and page.evaluate("() => window.viewerState.errors") == []
        finally:
            browser.close()
