"""The web server (aiohttp): the page, its static files, the rosbridge WebSocket and the MJPEG stream.

One port serves everything, so ``http://HOST:PORT/`` is the page and ``ws://HOST:PORT`` (what
``roslibpy.Ros(host, port)`` opens) the rosbridge v2 WebSocket: a request to ``/`` that asks to upgrade is
the WebSocket, any other is the page. The server runs its own asyncio loop on a thread of its own; the ROS
node's main thread only starts and stops it.

Routes: ``/`` (page or WebSocket), ``/static/...`` (the page's files, shipped in the package),
``/config.json`` (exposed topics, arbiters, drive limits), ``/network.svg`` (the robot's network),
``/stream?topic=T`` (MJPEG, like web_video_server) and ``/snapshot?topic=T`` (one JPEG).
"""
from __future__ import annotations

import asyncio
import logging
import socket
import threading
from importlib import resources
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web

from .config import Config
from .hub import Hub
from .network_view import NetworkView
from .protocol import NAME_PATTERN
from .security import cookie_name, host_is_local, origin_allowed, token_from_header, token_matches

LOG = logging.getLogger("terminal")
STATIC = Path(str(resources.files("terminal") / "static"))
BOUNDARY = "boundarydonotcross"  # web_video_server's
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' blob: data:; connect-src 'self' ws: wss:; "
                               "style-src 'self'; script-src 'self'; object-src 'none'; frame-ancestors 'none'; "
                               "base-uri 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",  # the token may be in the page's URL
    "Cache-Control": "no-store",
}


class WebServer:
    """The aiohttp application on a thread with its own loop."""

    def __init__(self, config: Config, hub: Hub, view: NetworkView | None, token: str | None,
                 namespace: str, node_name: str) -> None:
        self.config = config
        self.hub = hub
        self.view = view
        self.token = token
        self.namespace = namespace
        self.node_name = node_name
        self.port = config.port
        self.loop: asyncio.AbstractEventLoop | None = None
        self._runner: web.AppRunner | None = None
        self._thread: threading.Thread | None = None
        self._heartbeat_task: asyncio.Task | None = None  # kept: the loop holds tasks only weakly

    # Life cycle -------------------------------------------------------------------------------------------
    def start(self, timeout: float = 20.0) -> int:
        """Start listening; returns the port (the one the kernel chose for port 0). Raises OSError if it cannot."""
        started = threading.Event()
        failure: list[BaseException] = []

        def run() -> None:
            loop = asyncio.new_event_loop()
            asyncio.set_event_loop(loop)
            self.loop = loop
            try:
                loop.run_until_complete(self._start())
            except BaseException as error:  # handed to the starting thread, which reports it
                failure.append(error)
                # closed here, not by the garbage collector at exit: by then its file descriptors may be gone, and
                # "Exception ignored in BaseEventLoop.__del__" followed the one-line error (port in use)
                loop.run_until_complete(self._cleanup())
                loop.close()
                started.set()
                return
            started.set()
            loop.run_forever()
            loop.run_until_complete(self._cleanup())
            loop.close()

        self._thread = threading.Thread(target=run, name="terminal-web", daemon=True)
        self._thread.start()
        if not started.wait(timeout):
            raise OSError(f"the web server did not start within {timeout:g} s")
        if failure:
            raise failure[0]
        return self.port

    async def _start(self) -> None:
        self.hub.loop = asyncio.get_running_loop()
        app = web.Application(middlewares=[self._guard], client_max_size=self.config.max_message_bytes)
        app.router.add_get("/", self._root)
        app.router.add_get("/config.json", self._config_json)
        app.router.add_get("/network.svg", self._network_svg)
        app.router.add_get("/stream", self._stream)
        app.router.add_get("/snapshot", self._snapshot)
        app.router.add_static("/static/", STATIC, show_index=False, follow_symlinks=False)
        self._runner = web.AppRunner(app, handle_signals=False, access_log=None)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.config.host, self.config.port, reuse_address=True)
        await site.start()
        sockets = site._server.sockets if site._server is not None else []  # type: ignore[union-attr]
        if sockets:
            self.port = sockets[0].getsockname()[1]
        self._heartbeat_task = asyncio.get_running_loop().create_task(self._heartbeat())

    async def _heartbeat(self) -> None:
        """terminal/status once a second, so a late `rostopic echo` or a quiet page sees it."""
        while True:
            await asyncio.sleep(1.0)
            self.hub.status_changed()

    async def _cleanup(self) -> None:
        """Close the site and the connections, then end every task still pending (the heartbeat, senders), so
        the loop closes without "Task was destroyed but it is pending"."""
        if self._runner is not None:
            await self._runner.cleanup()
        pending = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
        for task in pending:
            task.cancel()
        await asyncio.gather(*pending, return_exceptions=True)

    def stop(self) -> None:
        """Stop the server's event loop and wait for its thread (at most 5 s)."""
        if self.loop is not None and self.loop.is_running():
            self.loop.call_soon_threadsafe(self.loop.stop)
        if self._thread is not None:
            self._thread.join(timeout=5)

    # Access ------------------------------------------------------------------------------------------------
    def _token_given(self, request: web.Request) -> tuple[str | None, str]:
        """The token the request shows, and where: header, query or cookie."""
        for where, value in (("header", token_from_header(request.headers.get("Authorization"))),
                             ("query", request.query.get("token")),
                             ("cookie", request.cookies.get(cookie_name(self.port)))):
            if value:
                return value, where
        return None, ""

    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        """Every request: the token when one is needed, else a Host naming this machine; security headers."""
        upgrade = request.headers.get("Upgrade", "").lower() == "websocket"
        request["authenticated"] = True
        if self.token is None:
            if not host_is_local(request.host, self.port):
                return self._refuse(403, f"Host {request.host!r} is not this machine: without a token the terminal "
                                         f"answers only to 127.0.0.1 and localhost")
        else:
            given, where = self._token_given(request)
            if given is None:
                if not upgrade:
                    return self._refuse(403, "This terminal needs a token: open the URL it printed at start "
                                             "(http://HOST:PORT/?token=...), or send 'Authorization: Bearer TOKEN'.")
                request["authenticated"] = False  # may still send rosbridge's auth op
            elif not token_matches(given, self.token):
                LOG.warning("terminal: wrong token from %s (%s) for %s", request.remote, where, request.path)
                return self._refuse(403, "Wrong token: this terminal refuses the request.")
            elif where == "query" and not upgrade and request.path == "/":
                # like Jupyter: trade the token in the URL for a cookie, and drop it from the address bar
                response = web.HTTPFound("/")
                response.set_cookie(cookie_name(self.port), given, httponly=True, samesite="Strict")
                self._secure(response)
                return response
        response = await handler(request)
        if not getattr(response, "prepared", False):
            self._secure(response)
        return response

    @staticmethod
    def _secure(response: web.StreamResponse) -> None:
        for key, value in SECURITY_HEADERS.items():
            response.headers.setdefault(key, value)

    def _refuse(self, status: int, text: str) -> web.Response:
        response = web.Response(status=status, text=text + "\n", content_type="text/plain")
        self._secure(response)
        return response

    # Page -------------------------------------------------------------------------------------------------
    async def _root(self, request: web.Request) -> web.StreamResponse:
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return await self._websocket(request)
        return web.FileResponse(STATIC / "index.html", headers={"Content-Type": "text/html; charset=utf-8"})

    async def _config_json(self, request: web.Request) -> web.Response:
        topics = {channel.role.role: {"name": channel.name, "type": channel.type,
                                      "command": channel.name in self.hub.commands}
                  for channel in self.hub.channels.values()}
        view = self.view
        return web.json_response({
            "node": self.node_name,
            "namespace": self.namespace,
            "topics": topics,
            "network": {"name": view.name, "level": view.level} if view else None,
            "arbiters": [a.as_json() for a in view.arbiters] if view else [],
            "drive": {"max_linear": self.config.max_linear, "max_angular": self.config.max_angular,
                      "period_ms": round(self.config.drive_period * 1000)},
            "deadman_timeout": self.config.deadman_timeout,
        })

    async def _network_svg(self, request: web.Request) -> web.Response:
        if self.view is None:
            return self._refuse(404, "No network file given (~network): nothing to draw.")
        return web.Response(text=self.view.svg, content_type="image/svg+xml")

    # MJPEG -----------------------------------------------------------------------------------------------
    def _camera(self, request: web.Request):
        topic = request.query.get("topic", "")
        channel = self.hub.stream_channel(topic) if NAME_PATTERN.match(topic) else None
        if channel is None:
            camera = self.hub.by_role.get("camera")
            offered = camera.name if camera else "none"
            raise web.HTTPNotFound(text=f"No camera topic {topic!r} here; this terminal streams {offered} "
                                        f"(GET {request.path}?topic={offered})\n")
        return channel

    async def _snapshot(self, request: web.Request) -> web.Response:
        encoded = await self.hub.current(self._camera(request))
        if encoded is None or encoded.jpeg is None:
            return self._refuse(503, "No camera frame has arrived yet.")
        return web.Response(body=encoded.jpeg, content_type="image/jpeg")

    async def _stream(self, request: web.Request) -> web.StreamResponse:
        """multipart/x-mixed-replace JPEGs, each frame as the camera sent it (no re-encoding of JPEGs)."""
        channel = self._camera(request)
        response = web.StreamResponse(headers={
            "Content-Type": f"multipart/x-mixed-replace;boundary={BOUNDARY}", **SECURITY_HEADERS})
        await response.prepare(request)
        channel.streams += 1
        self.hub.status_changed()
        try:
            seq = channel.seq
            encoded = await self.hub.current(channel)
            while True:
                if encoded is not None and encoded.jpeg is not None:
                    part = (f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(encoded.jpeg)}\r\n"
                            f"X-Timestamp: {encoded.stamp:.6f}\r\n\r\n").encode() + encoded.jpeg + b"\r\n"
                    await asyncio.wait_for(response.write(part), self.config.send_timeout)
                seq, encoded = await channel.next_frame(seq)
        except (ConnectionError, asyncio.TimeoutError, RuntimeError):
            pass  # the viewer went away or stopped reading
        finally:
            channel.streams -= 1
            self.hub.status_changed()
        return response

    # rosbridge ---------------------------------------------------------------------------------------------
    async def _websocket(self, request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if not origin_allowed(origin, request.host, self.config.allowed_origins):
            return self._refuse(403, f"Origin {origin} may not open this terminal's WebSocket (it is not the "
                                     f"terminal's own page); list it in ~allowed_origins to allow it.")
        if len(self.hub.sessions) >= self.config.max_clients:
            return self._refuse(503, f"Too many clients ({self.config.max_clients}); try again later.")
        ws = web.WebSocketResponse(max_msg_size=self.config.max_frame_bytes, compress=False, heartbeat=20.0)
        await ws.prepare(request)
        transport = request.transport
        self._bound_send_buffer(transport)
        loop = asyncio.get_running_loop()

        def close(reason: str) -> None:
            if reason == "not reading" and transport is not None:
                transport.abort()  # a close frame would wait behind the unread data
                return
            loop.create_task(self._close_after_replies(ws, session, reason))

        peer = request.remote or "?"
        session = self.hub.open_session(peer, ws.send_str, close, request["authenticated"])
        sender = loop.create_task(session.run_sender())
        timer = None
        if not session.authenticated:
            timer = loop.call_later(self.config.auth_timeout,
                                    lambda: None if session.authenticated else close("authentication timeout"))
        try:
            async for message in ws:
                if message.type == WSMsgType.TEXT:
                    self.hub.receive(session, message.data)
                elif message.type == WSMsgType.BINARY:
                    self.hub.binary(session)
                elif message.type == WSMsgType.ERROR:
                    break
        finally:
            if timer is not None:
                timer.cancel()
            self.hub.close_session(session)
            sender.cancel()
        return ws

    def _bound_send_buffer(self, transport: Any) -> None:
        """Keep what the kernel holds for one client small (``~send_buffer``).

        Linux grows a socket's send buffer up to megabytes; a client that reads slowly would then get frames
        seconds old, and one that never reads would go unnoticed for minutes. With a bounded buffer the
        server's writes wait instead, the client's queue keeps only the newest frame, and a client that
        takes nothing for ``~send_timeout`` is closed.
        """
        sock = transport.get_extra_info("socket") if transport is not None else None
        if sock is not None and self.config.send_buffer > 0:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.config.send_buffer)

    @staticmethod
    async def _close_after_replies(ws: web.WebSocketResponse, session: Any, reason: str) -> None:
        """Let the error reply go out first, then close with 1008 (policy violation)."""
        for _ in range(50):
            if not session.replies_pending:
                break
            await asyncio.sleep(0.02)
        await ws.close(code=1008, message=reason.encode()[:120])
