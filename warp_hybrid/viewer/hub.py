"""The newest frame and the pages watching it: the render thread publishes, never waits.

``publish`` (any thread) swaps in the newest packed frame and wakes every client's
sender on the server's event loop (``call_soon_threadsafe``: no lock held across a
send, no queue of frames).  A sender that was busy sending to a slow page finds only
the newest frame when it comes back (the ones in between are dropped).  Events
(small JSON messages) go to one client or all, each client keeping at most
``EVENT_BACKLOG`` of them.
"""

from __future__ import annotations

import asyncio
import itertools
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

EVENT_BACKLOG = 64


@dataclass
class Client:
    """One connected page: its id, pending events and the last frame it was sent."""

    id: int
    wakeup: asyncio.Event = field(default_factory=asyncio.Event)
    events: deque[dict[str, Any]] = field(default_factory=lambda: deque(maxlen=EVENT_BACKLOG))
    sent_index: int = -1


class FrameHub:
    """Holds the newest frame; hands it to every client's sender (module notes)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._latest: tuple[int, bytes] | None = None
        self._clients: dict[int, Client] = {}
        self._ids = itertools.count(1)
        self.published = 0

    def bind(self, loop: asyncio.AbstractEventLoop) -> None:
        """Deliver to senders running on ``loop`` (the server's)."""
        self._loop = loop

    def connect(self) -> Client:
        """Register a page (on the event loop)."""
        client = Client(next(self._ids))
        self._clients[client.id] = client
        if self._latest is not None:
            client.wakeup.set()
        return client

    def disconnect(self, client: Client) -> None:
        """Forget a page (on the event loop)."""
        self._clients.pop(client.id, None)

    @property
    def clients(self) -> list[Client]:
        """The connected pages."""
        return list(self._clients.values())

    def latest(self) -> tuple[int, bytes] | None:
        """The newest frame's publication number (0, 1, ...) and message, or None before the first."""
        with self._lock:
            return self._latest

    def publish(self, message: bytes) -> None:
        """Make ``message`` the newest frame and wake the senders (any thread, never blocks)."""
        with self._lock:
            self._latest = (self.published, message)
            self.published += 1
        self._call(self._wake_all)

    def send_event(self, event: dict[str, Any], client_id: int | None = None) -> None:
        """Queue ``event`` for one client (``client_id``) or for all (any thread)."""
        self._call(self._push_event, event, client_id)

    def _call(self, callback: Any, *args: Any) -> None:
        """Run ``callback`` on the server's loop; a no-op when it is not running."""
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        try:
            loop.call_soon_threadsafe(callback, *args)
        except RuntimeError:  # the loop closed in between
            pass

    def _wake_all(self) -> None:
        for client in self._clients.values():
            client.wakeup.set()

    def _push_event(self, event: dict[str, Any], client_id: int | None) -> None:
        targets = self._clients.values() if client_id is None else [self._clients.get(client_id)]
        for client in targets:
            if client is not None:
                client.events.append(event)
                client.wakeup.set()
