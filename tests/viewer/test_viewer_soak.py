"""Soak: two minutes of one page sending 100 pointer messages a second, another connecting and
disconnecting over and over, and a third that never reads; memory stays flat and the render
loop keeps the frame rate it had without any page (its own numbers, no absolute speeds).

``WARP_HYBRID_SOAK_S`` shortens or lengthens the loaded phase (default 120 s).
"""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path

import aiohttp
import pytest
from conftest import STILL, started, view_settings
from serverthread import ServerThread
from wsutil import message, until

SOAK_S = float(os.environ.get("WARP_HYBRID_SOAK_S", "120"))
BASELINE_S = 15.0
POINTER_HZ = 100.0
#: Connections per second of the churning page (at most).
CHURN_HZ = 10.0
#: The loaded loop keeps at least this share of the frame rate it had alone.
RATE_SHARE = 0.8
#: No two frame starts further apart than this many budgets.
MAX_STALL_BUDGETS = 6.0
#: Resident memory may grow this much over the loaded phase (allocator noise, logs).
RSS_GROWTH_MB = 40.0


def _rss_mb() -> float:
    """Resident memory of this process (Linux)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


async def _pointer_page(url: str, stop: float, counts: dict[str, int]) -> None:
    async with aiohttp.ClientSession() as session, session.ws_connect(url) as ws:
        await until(ws, "json", lambda m: m["type"] == "hello")

        async def read() -> None:
            async for msg in ws:
                if msg.type == aiohttp.WSMsgType.BINARY:
                    counts["pointer_page_frames"] += 1
                elif "error" in msg.data:
                    counts["refused"] += 1

        reader = asyncio.create_task(read())
        seq, start = 0, time.monotonic()
        while (now := time.monotonic()) < stop:
            seq += 1
            x = 0.5 + 0.4 * ((seq % 200) / 100.0 - 1.0)
            await ws.send_str(message("pointer", x=abs(x), y=0.5, seq=seq, sent_ms=1000.0 * (now - start)))
            await asyncio.sleep(max(0.0, start + seq / POINTER_HZ - time.monotonic()))
        counts["pointer_messages"] = seq
        reader.cancel()


async def _churning_page(url: str, stop: float, counts: dict[str, int]) -> None:
    async with aiohttp.ClientSession() as session:
        while time.monotonic() < stop:
            async with session.ws_connect(url) as ws:
                await until(ws, "json", lambda m: m["type"] == "hello", timeout=30)
                if counts["connections"] % 2:
                    await until(ws, "frame", timeout=30)
            counts["connections"] += 1
            await asyncio.sleep(1.0 / CHURN_HZ)


async def _stalled_page(url: str, stop: float) -> None:
    async with aiohttp.ClientSession() as session, session.ws_connect(url, max_msg_size=0) as ws:
        await asyncio.sleep(max(0.0, stop - time.monotonic()))  # never reads
        await ws.close()


async def _load(url: str, seconds: float) -> dict[str, int]:
    counts = {"pointer_messages": 0, "pointer_page_frames": 0, "refused": 0, "connections": 0}
    stop = time.monotonic() + seconds
    await asyncio.gather(_pointer_page(url, stop, counts), _churning_page(url, stop, counts), _stalled_page(url, stop))
    return counts


@pytest.mark.soak
def test_the_loop_keeps_its_rate_and_memory_under_two_minutes_of_pages(tmp_path: Path) -> None:
    viewer = started(STILL, view_settings(tmp_path))
    thread, health = viewer.thread, viewer.thread.health
    budget_s = thread.loop.settings.budget / 1000.0
    try:
        time.sleep(2.0)  # the first frames after the warm-up
        frames0, t0 = health.frames, time.monotonic()
        time.sleep(BASELINE_S)
        alone = (health.frames - frames0) / (time.monotonic() - t0)
        health.reset_interval()
        with ServerThread(viewer) as server:
            url = f"{server.url}ws"
            rss = {}

            async def run() -> dict[str, int]:
                load = asyncio.create_task(_load(url, SOAK_S))
                await asyncio.sleep(min(30.0, SOAK_S / 4))
                rss["start"], frames1, t1 = _rss_mb(), health.frames, time.monotonic()
                counts = await load
                counts["loaded_frames"], counts["loaded_s"] = health.frames - frames1, time.monotonic() - t1
                rss["end"] = _rss_mb()
                return counts

            counts = asyncio.run(run())
        loaded = counts["loaded_frames"] / counts["loaded_s"]
        print(f"soak: alone {alone:.2f} fps, loaded {loaded:.2f} fps, {counts}, rss {rss}")
        assert loaded >= RATE_SHARE * alone, (alone, loaded)
        assert health.max_interval_s <= MAX_STALL_BUDGETS * budget_s, health.max_interval_s
        assert counts["pointer_messages"] >= 0.8 * POINTER_HZ * SOAK_S and counts["refused"] == 0
        assert counts["pointer_page_frames"] >= 0.5 * counts["loaded_frames"]
        assert counts["connections"] >= 0.3 * CHURN_HZ * SOAK_S
        assert rss["end"] - rss["start"] <= RSS_GROWTH_MB, rss
        assert viewer.hub.clients == []
    finally:
        thread.stop()
