"""The viewer's web server (aiohttp): its own static files and one WebSocket per page.

Routes: ``/`` (the viewer page), ``/calibrate`` (the webcam calibration page),
``/static/NAME`` (only the files in this package's ``static/`` folder, looked up by
name in a table built at start-up, so no path can leave it), ``/protocol.json``
(``protocol.schema_document``) and ``/ws``.  Every page is served with a
Content-Security-Policy that allows nothing from another origin.

Per WebSocket: a receive loop validates each text message (``protocol``); a refused
one is logged and answered with an ``error`` message, the connection stays up.  A
sender task is the only writer: it sends queued events, then the newest frame when it
is newer than the last one sent, so a slow page gets fewer frames, never old ones,
and a page that takes longer than ``SEND_TIMEOUT_S`` to take a frame is closed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path

from aiohttp import WSMsgType, web

from .hub import Client
from .protocol import MAX_MESSAGE_BYTES, ProtocolError, parse_client_message, schema_document, server_message
from .session import Viewer

log = logging.getLogger("warp_hybrid.viewer")

STATIC_DIR = Path(__file__).resolve().parent / "static"
CONTENT_TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css", ".png": "image/png"}
CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob:; "
    "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
)
SEND_TIMEOUT_S = 10.0
HEARTBEAT_S = 10.0
VIEWER_KEY: web.AppKey[Viewer] = web.AppKey("viewer", Viewer)


def static_files(folder: Path = STATIC_DIR) -> dict[str, Path]:
    """The servable files: every regular file directly in ``folder`` of a known type, by name."""
    return {p.name: p for p in sorted(folder.iterdir()) if p.is_file() and p.suffix in CONTENT_TYPES}


def _file_response(path: Path) -> web.Response:
    return web.Response(
        body=path.read_bytes(),
        content_type=CONTENT_TYPES[path.suffix],
        headers={"Content-Security-Policy": CSP, "Cache-Control": "no-cache", "X-Content-Type-Options": "nosniff"},
    )


def create_app(viewer: Viewer, manage_thread: bool = True) -> web.Application:
    """The aiohttp application for ``viewer``; with ``manage_thread`` its render thread
    starts and stops with the app (else the caller runs it, e.g. across test apps)."""
    files = static_files()
    app = web.Application()
    app[VIEWER_KEY] = viewer

    async def page(name: str) -> web.Response:
        return _file_response(files[name])

    async def index(request: web.Request) -> web.Response:
        return await page("index.html")

    async def calibrate(request: web.Request) -> web.Response:
        return await page("calibrate.html")

    async def static(request: web.Request) -> web.Response:
        path = files.get(request.match_info["name"])
        if path is None:
            raise web.HTTPNotFound()
        return _file_response(path)

    async def protocol(request: web.Request) -> web.Response:
        return web.json_response(schema_document())

    async def on_startup(app: web.Application) -> None:
        viewer.hub.bind(asyncio.get_running_loop())
        if manage_thread:
            viewer.thread.start()

    async def on_cleanup(app: web.Application) -> None:
        if manage_thread:
            await asyncio.get_running_loop().run_in_executor(None, viewer.thread.stop)

    app.router.add_get("/", index)
    app.router.add_get("/calibrate", calibrate)
    app.router.add_get("/static/{name}", static)
    app.router.add_get("/protocol.json", protocol)
    app.router.add_get("/ws", websocket)
    app.on_startup.append(on_startup)
    app.on_cleanup.append(on_cleanup)
    return app


async def websocket(request: web.Request) -> web.WebSocketResponse:
    """One page's WebSocket: validated messages in, events and the newest frames out."""
    viewer = request.app[VIEWER_KEY]
    ws = web.WebSocketResponse(heartbeat=HEARTBEAT_S, max_msg_size=MAX_MESSAGE_BYTES)
    await ws.prepare(request)
    client = viewer.hub.connect()
    client.events.append(viewer.hello(client.id))
    client.wakeup.set()
    sender = asyncio.create_task(_send(ws, client, viewer))
    try:
        async for msg in ws:
            if msg.type == WSMsgType.TEXT:
                _receive(viewer, client, msg.data)
            elif msg.type == WSMsgType.BINARY:
                _refuse(viewer, client, "binary messages are not accepted; send JSON text")
    finally:
        sender.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await sender
        viewer.hub.disconnect(client)
    return ws


def _receive(viewer: Viewer, client: Client, text: str) -> None:
    try:
        viewer.handle(client.id, parse_client_message(text))
    except ProtocolError as exc:
        _refuse(viewer, client, str(exc))


def _refuse(viewer: Viewer, client: Client, problem: str) -> None:
    log.warning("page %d: message refused: %s", client.id, problem)
    client.events.append(server_message("error", message=problem))
    client.wakeup.set()


async def _send(ws: web.WebSocketResponse, client: Client, viewer: Viewer) -> None:
    """The page's only writer (module notes)."""
    try:
        while not ws.closed:
            await client.wakeup.wait()
            client.wakeup.clear()
            while client.events:
                await asyncio.wait_for(ws.send_json(client.events.popleft()), SEND_TIMEOUT_S)
            latest = viewer.hub.latest()
            if latest is not None and latest[0] != client.sent_index:
                index, message = latest
                await asyncio.wait_for(ws.send_bytes(message), SEND_TIMEOUT_S)
                client.sent_index = index
    except asyncio.TimeoutError:
        log.warning("page %d: closing a stalled connection (no frame taken in %g s)", client.id, SEND_TIMEOUT_S)
        await ws.close()
    except ConnectionError:
        log.info("page %d: connection lost", client.id)
