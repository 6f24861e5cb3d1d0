"""A viewer served on a loopback port from a thread of its own (for a browser or a soak client)."""

from __future__ import annotations

import asyncio
import threading
from types import TracebackType

from aiohttp import web

from warp_hybrid.viewer.server import create_app
from warp_hybrid.viewer.session import Viewer


class ServerThread:
    """Serves ``viewer`` on 127.0.0.1 (a free port) while the ``with`` block runs; the
    caller runs the render thread."""

    def __init__(self, viewer: Viewer) -> None:
        self.viewer = viewer
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, name="viewer test server", daemon=True)
        self._runner: web.AppRunner | None = None

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://127.0.0.1:{self.port}/"

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        self._loop.run_until_complete(self._start())
        self._ready.set()
        self._loop.run_forever()
        self._loop.run_until_complete(self._runner.cleanup() if self._runner else asyncio.sleep(0))
        self._loop.close()

    async def _start(self) -> None:
        self._runner = web.AppRunner(create_app(self.viewer, manage_thread=False), access_log=None)
        await self._runner.setup()
        site = web.TCPSite(self._runner, "127.0.0.1", 0)
        await site.start()
        self.port = self._runner.addresses[0][1]

    def __enter__(self) -> ServerThread:
        self._thread.start()
        assert self._ready.wait(60), "the test server did not start"
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(60)
