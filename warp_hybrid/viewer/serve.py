"""``warp-hybrid view``: build the viewer for a scene and serve it until Ctrl-C."""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import sys

from aiohttp import web
from aiohttp.web_runner import GracefulExit

from ..errors import RenderSettingsError
from ..scene.usd.loader import UsdSceneSource
from .hub import FrameHub
from .render_thread import RenderThread, ViewSettings
from .server import create_app
from .session import Viewer

LOOPBACK_HOSTS = ("localhost",)


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    if host in LOOPBACK_HOSTS:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def url_for(host: str, port: int) -> str:
    """The page's address (IPv6 hosts in brackets)."""
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


def build_viewer(source: UsdSceneSource, settings: ViewSettings) -> Viewer:
    """The viewer for ``source`` (its render thread built, not started)."""
    hub = FrameHub()
    return Viewer(RenderThread(source, settings, hub), hub)


def serve(viewer: Viewer, host: str, port: int) -> None:
    """Serve ``viewer`` on ``host:port`` until Ctrl-C or SIGTERM; prints the URL once
    listening (and a warning first when the host is reachable from other machines)."""
    if not 0 <= port <= 65535:
        raise RenderSettingsError(f"--port must lie in 0..65535, got {port}")
    if not is_loopback(host):
        print(
            f"warning: listening on {host}: anyone who can reach this machine can watch and steer the viewer",
            file=sys.stderr,
        )
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    try:
        asyncio.run(_serve(create_app(viewer), host, port))
    except (KeyboardInterrupt, GracefulExit):
        pass


async def _serve(app: web.Application, host: str, port: int) -> None:
    runner = web.AppRunner(app, handle_signals=True, access_log=None)
    await runner.setup()
    try:
        try:
            await web.TCPSite(runner, host, port).start()
        except OSError as exc:
            raise RenderSettingsError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        bound = runner.addresses[0][1] if runner.addresses else port
        print(f"viewer: {url_for(host, bound)} (Ctrl-C to stop)", flush=True)
        await asyncio.Event().wait()
    finally:
        await runner.cleanup()
