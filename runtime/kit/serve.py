"""Running an ASGI app with uvicorn on a socket we own (so the port is known up front, and a
launcher can keep it open across restarts of the process behind it), over TLS where asked,
and beside it other listeners of the same process (a plain port beside an HTTPS one)."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import ssl
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

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


@dataclass
class Listener:
    """An app served on sockets, over TLS with `tls` (a server context's maker)."""

    app: ASGIApp
    sockets: list[socket.socket]
    tls: Callable[[], ssl.SSLContext] | None = None
    lifespan: bool = field(default=False, init=False)


GRACEFUL_SHUTDOWN = 3  # s a server's open connections have to finish when it stops
# With several servers the leader's connections wait for the followers' to close: 2 s each,
# so that together they end within the 5 s the launcher allows a stopping process.
GRACEFUL_SHUTDOWN_EACH = 2


def _config(listener: Listener, graceful: int = GRACEFUL_SHUTDOWN) -> uvicorn.Config:
    tls = listener.tls
    return uvicorn.Config(
        listener.app,
        log_config=None,
        access_log=False,
        lifespan="on" if listener.lifespan else "off",
        timeout_graceful_shutdown=graceful,
        # Longer than any client of ours keeps an idle connection (httpx: 5 s). With both at
        # 5 s a client could send on a connection the server was closing that instant, and
        # the request failed ("server disconnected": a 503 at the gateway, seen now and then
        # in the browser tests).
        timeout_keep_alive=30,
        ws_ping_interval=5.0,
        ws_ping_timeout=5.0,
        ssl_context_factory=None if tls is None else lambda _config, _default: tls(),
    )


class _Leader(uvicorn.Server):
    """The first server of a process with several: it runs the app's lifespan and handles
    the signals; on the way out it waits for the others to close their connections (a held
    jog's socket halts its robot as it closes) before the app shuts down."""

    def __init__(self, config: uvicorn.Config) -> None:
        super().__init__(config)
        self.followers: list[_Follower] = []

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        await asyncio.gather(*(f.finished.wait() for f in self.followers))
        await super().shutdown(sockets)


class _Follower(uvicorn.Server):
    """Another server of the process: it starts once the leader has (whose lifespan, the
    app's start-up, it shares), stops when the leader is told to, and is forced out with it."""

    def __init__(self, config: uvicorn.Config, leader: _Leader) -> None:
        self.leader = leader
        self._forced = False
        super().__init__(config)
        self.finished = asyncio.Event()
        self.failed: Exception | None = None
        leader.followers.append(self)

    @property
    def force_exit(self) -> bool:
        return self._forced or self.leader.force_exit

    @force_exit.setter
    def force_exit(self, value: bool) -> None:
        self._forced = value

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield

    async def serve(self, sockets: list[socket.socket] | None = None) -> None:
        try:
            while not self.leader.started:
                if self.leader.should_exit:
                    return
                await asyncio.sleep(0.01)
            await super().serve(sockets)
        except Exception as exc:
            # Not the leader's (nor the app's shutdown) to be cancelled by: it stops, and
            # the process ends with this error once it has.
            self.failed = exc
            self.leader.should_exit = True
        finally:
            self.finished.set()

    async def on_tick(self, counter: int) -> bool:
        return self.leader.should_exit or await super().on_tick(counter)


def run_listeners(first: Listener, *others: Listener) -> None:
    """Serve until SIGTERM or SIGINT; `first` runs the app's lifespan."""
    first.lifespan = True
    if not others:
        uvicorn.Server(_config(first)).run(sockets=first.sockets)
        return

    graceful = GRACEFUL_SHUTDOWN_EACH

    async def serve_all() -> None:
        # Made in the loop that serves them (their events belong to it).
        leader = _Leader(_config(first, graceful))
        followers = [(_Follower(_config(o, graceful), leader), o.sockets) for o in others]
        await asyncio.gather(
            leader.serve(first.sockets), *(f.serve(sockets) for f, sockets in followers)
        )
        for follower, _ in followers:
            if follower.failed is not None:
                raise follower.failed

    # The event loop uvicorn would choose for one server (uvloop where installed).
    with asyncio.Runner(loop_factory=_config(first).get_loop_factory()) as runner:
        runner.run(serve_all())


def run_app(app: ASGIApp, *sockets: socket.socket) -> None:
    run_listeners(Listener(app, list(sockets)))
