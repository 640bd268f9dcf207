"""Running an ASGI app with uvicorn on a socket we own (so the port is known up front, and a
launcher can keep it open across restarts of the process behind it)."""

from __future__ import annotations

import socket

import uvicorn
from starlette.types import ASGIApp


def listening_socket(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


def run_app(app: ASGIApp, *sockets: socket.socket) -> None:
    config = uvicorn.Config(
        app,
        log_config=None,
        access_log=False,
        lifespan="on",
        timeout_graceful_shutdown=3,
        # Longer than any client of ours keeps an idle connection (httpx: 5 s). With both at
        # 5 s a client could send on a connection the server was closing that instant, and
        # the request failed ("server disconnected": a 503 at the gateway, seen now and then
        # in the browser tests).
        timeout_keep_alive=30,
        ws_ping_interval=5.0,
        ws_ping_timeout=5.0,
    )
    uvicorn.Server(config).run(sockets=list(sockets))
