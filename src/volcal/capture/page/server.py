"""The technician's page: a small local web server (aiohttp) beside the capture.

``volcal capture ... --serve [--host 127.0.0.1] [--port 8765]`` starts it in a thread of
its own while the capture runs in the main thread. It serves

==================  ===================================================================
``GET /``           the page (``static/index.html``, its script and style sheet, all
                    served from the package: no CDN, works without the internet)
``GET /api/state``  the live state as JSON (:meth:`LiveState.snapshot`)
``GET /events``     the same, pushed as server-sent events (``text/event-stream``)
                    whenever it changes, at most every ``PUSH_S`` seconds
``POST /api/typed`` a typed reading, JSON ``{"value": 12.3, "unit": "um"}``, for the
                    ``typed`` laser source
==================  ===================================================================

It binds to 127.0.0.1 unless told otherwise: another host on the shop network can then
neither watch nor type. A POST must carry ``Content-Type: application/json``, which a page
of another site cannot send without a CORS preflight this server never grants.

aiohttp (PyPI, the ``capture`` extra) was chosen because it is one well-kept library that
serves HTTP and server-sent events on asyncio without a separate ASGI server; the OPC UA
client of the same extra (asyncua) is asyncio too (docs/capture_page.md).
"""

from __future__ import annotations

import asyncio
import json
import threading
from importlib import resources
from typing import Any

from volcal.capture.page.state import LiveState
from volcal.errors import VolcalInputError
from volcal.extras import require_extra

__all__ = ["PUSH_S", "Page", "PageServer"]

PUSH_S = 0.25
"""Interval of the server-sent events [s] (a state that did not change is not sent, but
the silence of a source is counted on every push)."""

STATIC = {"index.html": "text/html", "page.js": "text/javascript",
          "page.css": "text/css", "icon.svg": "image/svg+xml"}
"""The page's files (``volcal/capture/page/static/``) and their media types."""

CSP = ("default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; "
       "connect-src 'self'; frame-ancestors 'none'")
"""Content security policy: the page loads nothing from anywhere else."""


def _asset(name: str) -> bytes:
    return (resources.files("volcal.capture.page") / "static" / name).read_bytes()


class PageServer:
    """The page's HTTP server, run in a background thread.

    Parameters
    ----------
    state : LiveState
        What the page shows.
    host : str
        Address to bind (``127.0.0.1``: this computer only).
    port : int
        TCP port (0: any free port; :attr:`url` tells which).
    """

    def __init__(self, state: LiveState, host: str = "127.0.0.1", port: int = 8765) -> None:
        require_extra("capture", "volcal capture --serve", ("aiohttp",))
        self.state = state
        self.host = host
        self.port = int(port)
        self.url = ""
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._runner: Any = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._closing = False

    # ------------------------------------------------------------------ app
    def app(self) -> Any:
        """The aiohttp application (routes of the module's docstring)."""
        from aiohttp import web

        app = web.Application(client_max_size=16 * 1024)
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static)
        app.router.add_get("/api/state", self._state)
        app.router.add_get("/events", self._events)
        app.router.add_post("/api/typed", self._typed)
        return app

    @staticmethod
    def _headers() -> dict[str, str]:
        return {"Content-Security-Policy": CSP, "Cache-Control": "no-store",
                "X-Content-Type-Options": "nosniff"}

    async def _index(self, request: Any) -> Any:
        from aiohttp import web

        return web.Response(body=_asset("index.html"), content_type="text/html",
                            charset="utf-8", headers=self._headers())

    async def _static(self, request: Any) -> Any:
        from aiohttp import web

        name = request.match_info["name"]
        if name not in STATIC:
            raise web.HTTPNotFound()
        return web.Response(body=_asset(name), content_type=STATIC[name],
                            headers=self._headers())

    async def _state(self, request: Any) -> Any:
        from aiohttp import web

        return web.json_response(self.state.snapshot(), headers=self._headers())

    async def _events(self, request: Any) -> Any:
        from aiohttp import web

        resp = web.StreamResponse(headers={**self._headers(),
                                           "Content-Type": "text/event-stream",
                                           "X-Accel-Buffering": "no"})
        await resp.prepare(request)
        last_text, last_points = "", -1
        try:
            while not self._closing:
                snap = self.state.snapshot(with_points=False)
                if snap["points_version"] != last_points:
                    snap = self.state.snapshot(with_points=True)
                    last_points = snap["points_version"]
                text = json.dumps(snap, separators=(",", ":"))
                if text != last_text:
                    await resp.write(f"data: {text}\n\n".encode())
                    last_text = text
                await asyncio.sleep(PUSH_S)
        except (ConnectionResetError, asyncio.CancelledError):
            pass
        return resp

    async def _typed(self, request: Any) -> Any:
        from aiohttp import web

        if request.content_type != "application/json":
            return web.json_response({"error": "send JSON (Content-Type: application/json)"},
                                     status=415)
        try:
            body = await request.json()
            value = body.get("value") if isinstance(body, dict) else None
            if isinstance(value, str):
                value = float(value.replace(",", ".").strip())
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise VolcalInputError(f"typed reading {value!r}: expected a number")
            entry = self.state.typed_put(float(value), str(body.get("unit", "um")),
                                         str(body.get("note", "")))
        except (ValueError, VolcalInputError) as e:
            return web.json_response({"error": str(e)}, status=400)
        return web.json_response(entry, headers=self._headers())

    # ------------------------------------------------------------------ thread
    def start(self, wait_s: float = 10.0) -> str:
        """Serve in a background thread; returns the page's URL.

        Parameters
        ----------
        wait_s : float
            Longest wait for the server to listen [s].

        Returns
        -------
        str
            The page's URL (``http://127.0.0.1:PORT/``).

        Raises
        ------
        VolcalInputError
            The address cannot be bound (port in use, no such address).
        """
        self._thread = threading.Thread(target=self._run, name="volcal-page", daemon=True)
        self._thread.start()
        self._ready.wait(wait_s)
        if self._error is not None:
            raise VolcalInputError(f"cannot serve the capture page on {self.host}:{self.port}: "
                                   f"{self._error}") from None
        return self.url

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        asyncio.set_event_loop(loop)
        try:
            loop.run_until_complete(self._serve())
        except Exception as e:  # bind errors: reported by start()
            self._error = e
            loop.close()  # nothing left running on it (no unclosed loop left behind)
            self._ready.set()
            return
        self._ready.set()
        loop.run_forever()
        loop.run_until_complete(self._runner.cleanup())
        loop.close()

    async def _serve(self) -> None:
        from aiohttp import web

        runner = web.AppRunner(self.app(), access_log=None, shutdown_timeout=1.0)
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port)
        await site.start()
        self._runner = runner
        port = runner.addresses[0][1] if runner.addresses else self.port
        host = self.host if ":" not in self.host else f"[{self.host}]"
        self.url = f"http://{host}:{port}/"

    def stop(self) -> None:
        """Stop serving (the open event streams end)."""
        self._closing = True
        if self._loop is not None and self._loop.is_running():
            self._loop.call_soon_threadsafe(self._loop.stop)
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._thread = None


class Page:
    """The page of one capture: its state, its server, and what the capture is handed.

    Parameters
    ----------
    title : str
        The page's heading (the session).
    control, laser : str
        The ``SOURCE`` texts; with ``laser`` ``typed`` the page takes typed readings.
    host : str
        Address to bind (``127.0.0.1``: this computer only).
    port : int
        TCP port (0: any free one).
    window_mm : float
        The trigger rule's target window [mm] (for the indicator).
    stale_s : float
        A source silent this long gets a banner [s].

    Attributes
    ----------
    url : str
        Where the page is served.
    observer : LiveState
        The capture's observer (``volcal.steps.capture.capture(observer=...)``).
    extras : dict
        The capture's ``extras`` (the typed readings' queue).
    """

    def __init__(self, title: str, control: str, laser: str, host: str = "127.0.0.1",
                 port: int = 8765, window_mm: float = 0.010, stale_s: float = 2.0) -> None:
        from volcal.capture.typed import EXTRAS_KEY, TypedQueue

        typed = TypedQueue() if laser.partition(":")[0].strip().lower() == "typed" else None
        self.observer = LiveState(title, typed=typed, window_mm=window_mm, stale_s=stale_s)
        self.observer.set_sources(control, laser)
        self.extras: dict[str, Any] = {EXTRAS_KEY: typed} if typed is not None else {}
        self.server = PageServer(self.observer, host, port)
        self.url = self.server.start()

    def close(self, message: str = "capture finished", error: str | None = None) -> None:
        """Show the end on the page (one last push), then stop serving.

        Parameters
        ----------
        message : str
            What the page says of the end.
        error : str, optional
            Why the capture stopped (shown as a banner).
        """
        import time

        self.observer.finish(message, error)
        time.sleep(2.0 * PUSH_S + 0.1)
        self.server.stop()

    def __enter__(self) -> Page:
        return self

    def __exit__(self, typ: Any, exc: Any, tb: Any) -> None:
        if exc is None:
            self.close()
        else:
            self.close("capture stopped", str(exc) or type(exc).__name__)
