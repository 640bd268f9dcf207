"""A forwarded request's deadline: the webui stamps what it forwards with `X-Deadline`
(seconds since the epoch), a little before it gives up and answers 504 itself. A service
refuses a request whose deadline has passed, and the variable storage checks it again just
before it commits: a request the gateway answered with an error is never applied later
(say by a storage that restarted with requests waiting in its listening socket), so it
cannot overwrite a newer write either."""

from __future__ import annotations

import json
import math
import time
from contextvars import ContextVar

from starlette.types import ASGIApp, Receive, Scope, Send

from openpendant.runtime.kit.errors import OpenPendantError

HEADER = "X-Deadline"
_HEADER_KEY = HEADER.lower().encode()
# The gateway waits this long for a service; the deadline it stamps is earlier by the
# margin, the time left for an answer to get back before the gateway gives up.
GATEWAY_TIMEOUT = 10.0
MARGIN = 1.0

current: ContextVar[float | None] = ContextVar("deadline", default=None)


class DeadlinePassed(OpenPendantError):
    status = 504
    code = "deadline_passed"


def for_request(received: float, timeout: float = GATEWAY_TIMEOUT) -> str:
    return f"{received + timeout - MARGIN:.6f}"


def check() -> None:
    deadline = current.get()
    if deadline is not None and time.time() > deadline:
        raise DeadlinePassed(
            "the request waited past its deadline (the gateway has answered it already); "
            "nothing was changed"
        )


def parse(raw: bytes) -> float | None:
    try:
        value = float(raw)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


class DeadlineMiddleware:
    """Sets the request's deadline for everything it does, and refuses it once passed."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        deadline = None
        for key, value in scope.get("headers", ()):
            if key == _HEADER_KEY:
                deadline = parse(value)
        if deadline is not None and time.time() > deadline:
            body = DeadlinePassed("the request waited past its deadline; nothing was done")
            await _respond(send, body)
            return
        token = current.set(deadline)
        try:
            await self.app(scope, receive, send)
        finally:
            current.reset(token)


async def _respond(send: Send, error: DeadlinePassed) -> None:
    payload = json.dumps(error.body()).encode()
    await send(
        {
            "type": "http.response.start",
            "status": error.status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(payload)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": payload})
