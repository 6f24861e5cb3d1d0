"""WebSocket helpers for the viewer tests: read until a frame or an event that matches."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

from aiohttp import ClientWebSocketResponse, WSMsgType

from warp_hybrid.viewer.protocol import unpack_frame

#: Seconds a test waits for a frame or a message (a mode change compiles kernels on the first run).
TIMEOUT_S = 300.0


async def receive(ws: ClientWebSocketResponse, timeout: float) -> tuple[str, Any]:
    """The next message as ("json", object) or ("frame", (header, jpeg))."""
    msg = await ws.receive(timeout=timeout)
    if msg.type == WSMsgType.TEXT:
        return "json", json.loads(msg.data)
    if msg.type == WSMsgType.BINARY:
        return "frame", unpack_frame(msg.data)
    raise AssertionError(f"the connection ended: {msg.type} {msg.data!r}")


async def until(
    ws: ClientWebSocketResponse,
    kind: str,
    predicate: Callable[[Any], bool] = lambda _: True,
    timeout: float = TIMEOUT_S,
    seen: list[dict[str, Any]] | None = None,
) -> Any:
    """The first message of ``kind`` ("json" or "frame") that ``predicate`` accepts (JSON
    messages passed on the way are appended to ``seen``)."""
    end = time.monotonic() + timeout
    while True:
        left = end - time.monotonic()
        if left <= 0:
            raise AssertionError(f"no matching {kind} message within {timeout} s")
        got, value = await receive(ws, left)
        if got == "json" and seen is not None:
            seen.append(value)
        if got == kind and predicate(value):
            return value


def message(message_type: str, /, **fields: Any) -> str:
    """A protocol message from a page."""
    return json.dumps({"v": 1, "type": message_type, **fields})


async def frame_with_state(ws: ClientWebSocketResponse, **state: Any) -> dict[str, Any]:
    """The header of the first frame whose state holds ``state``."""
    header, _ = await until(ws, "frame", lambda f: all(f[0]["state"].get(k) == v for k, v in state.items()))
    return header
