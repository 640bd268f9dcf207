"""Two servers of one process, for `unit/test_tls.py`: the jog service's shape, a plain port
and a public one over TLS serving one app whose start-up (lifespan) runs once.

`python -m tests.support.two_listeners held|no_context PLAIN_FD SECURE_FD CERT KEY JOURNAL`
serves on the two listening sockets it inherits until SIGTERM. `held`: `GET /ready` and a
WebSocket `/held` that takes half a second to close; `no_context`: the TLS context cannot be
made (exit status 3). What happens on the way out is appended to JOURNAL.

A process of its own, started fresh, not a fork of the test's: a fork of a process with
threads (pytest-xdist's, earlier tests') can inherit a lock some thread held at that instant
and hang on it; once, in CI, the server never answered a WebSocket handshake."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import ssl
import sys
from collections.abc import AsyncIterator, Callable
from pathlib import Path

from fastapi import FastAPI, WebSocket, WebSocketDisconnect

from openpendant.runtime.kit.serve import Listener, run_listeners
from openpendant.runtime.kit.tls import TlsFiles

NO_CONTEXT_EXIT = 3


def app_noting_in(journal: Path) -> FastAPI:
    def note(line: str) -> None:
        with journal.open("a") as out:
            out.write(line + "\n")

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        app.state.ready = "yes"
        yield
        note("app shut down")

    app = FastAPI(lifespan=lifespan)

    @app.get("/ready")
    async def ready() -> dict[str, str]:
        return {"ready": app.state.ready}

    @app.websocket("/held")
    async def held(socket: WebSocket) -> None:
        await socket.accept()
        try:
            while True:
                await socket.receive_text()
        except WebSocketDisconnect:
            pass
        finally:
            await asyncio.sleep(0.5)  # a halt on the way out takes its time
            note("socket closed")

    return app


def no_context() -> ssl.SSLContext:
    raise ssl.SSLError("no certificate")


def main(argv: list[str]) -> int:
    mode, plain_fd, secure_fd, cert, key, journal = argv
    plain = socket.socket(fileno=int(plain_fd))
    secure = socket.socket(fileno=int(secure_fd))
    context: Callable[[], ssl.SSLContext] = no_context
    if mode == "held":
        context = TlsFiles(cert=Path(cert), key=Path(key), ca=None).server_context
    app = app_noting_in(Path(journal))
    try:
        run_listeners(Listener(app, [plain]), Listener(app, [secure], context))
    except ssl.SSLError:
        return NO_CONTEXT_EXIT
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
