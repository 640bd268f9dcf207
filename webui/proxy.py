"""Forwarding /api/<prefix>/… to the service that owns <prefix>, over HTTP and WebSocket."""

from __future__ import annotations

import contextlib
import json
import time
from urllib.parse import quote

import httpx
import websockets
from fastapi import Request, Response, WebSocket
from starlette.requests import HTTPConnection
from starlette.websockets import WebSocketDisconnect

from openpendant.runtime.interfaces.common import plain_text
from openpendant.runtime.kit import deadline
from openpendant.runtime.kit.app import error_response
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.internal import HEADER as INTERNAL_HEADER
from openpendant.runtime.kit.internal import internal_headers
from openpendant.runtime.kit.request_start import HEADER as REQUEST_START
from openpendant.runtime.kit.request_start import stamp
from openpendant.runtime.kit.uploads import UPLOAD_TIMEOUT, UPLOADS
from openpendant.runtime.kit.websocket import until_either_ends

USER_HEADER = "X-OpenPendant-User"
ROLE_HEADER = "X-OpenPendant-Role"

# Hop-by-hop and length headers, and the arrival stamp, are the proxy's own business; what a
# client says of proxies before it (X-Forwarded-*, Forwarded) is never passed on as if true.
_SKIP_REQUEST = {
    REQUEST_START.lower(),
    deadline.HEADER.lower(),
    "host",
    "connection",
    "content-length",
    "transfer-encoding",
    "upgrade",
    "keep-alive",
    "te",
    "trailer",
    "proxy-authorization",
    "proxy-authenticate",
    "proxy-connection",
    "accept-encoding",
    "forwarded",
    # The client's credentials stay at the gateway; services learn who from the gateway.
    "cookie",
    "authorization",
    "origin",
    INTERNAL_HEADER.lower(),
    USER_HEADER.lower(),
    ROLE_HEADER.lower(),
}
LOOPBACK = "http://127.0.0.1"


def identity_headers(connection: HTTPConnection) -> dict[str, str]:
    """Who the gateway let through (services may name them; they never decide on it)."""
    identity = connection.scope.get("state", {}).get("identity")
    if identity is None:
        return {}
    return {USER_HEADER: identity.user, ROLE_HEADER: identity.role.name}


BAD_PATH = "a path may not hold . or .. segments, backslashes or control characters"


def forwarded_headers(request: Request) -> dict[str, str]:
    named = {
        token.strip().lower()
        for token in request.headers.get("connection", "").split(",")
        if token.strip()
    }
    return {
        k: v
        for k, v in request.headers.items()
        if (key := k.lower()) not in _SKIP_REQUEST
        and key not in named
        and not key.startswith("x-forwarded-")
    }


def service_path(path: str) -> str:
    """The path below a service's prefix, each segment quoted again: a `..` (or an encoded
    slash that would make one) never climbs out of the prefix to another route."""
    segments = path.split("/")
    if any(s in (".", "..") for s in segments) or "\\" in path:
        raise PathRefused(path)
    try:
        plain_text(path)
    except ValueError:
        raise PathRefused(path) from None
    return "/".join(quote(s, safe="!$&'()*+,;=:@~-._") for s in segments)


def below_prefix(full_path: str, prefix: str) -> str:
    """What follows /api/<prefix>/ in the request's whole path. Routing's own match drops a
    trailing newline (`$`), so the path is taken from the request, not from the match."""
    head = f"/api/{prefix}"
    if not full_path.startswith(head):
        raise PathRefused(full_path)
    rest = full_path[len(head) :]
    if rest and not rest.startswith("/"):
        raise PathRefused(full_path)
    plain = rest.removeprefix("/")
    service_path(plain)
    return plain


class PathRefused(ValueError):
    pass


_KEEP_RESPONSE = {"content-type", "content-disposition", "cache-control", "etag"}


class ServiceProxy:
    def __init__(self, routes: dict[str, tuple[str, str]]) -> None:
        """routes: prefix -> (service name, base url)"""
        self.routes = routes
        # Long work is a resource with a status, never a long request: 10 s means hung.
        self.http = httpx.AsyncClient(
            timeout=httpx.Timeout(deadline.GATEWAY_TIMEOUT, connect=2.0),
            headers=internal_headers(LOOPBACK),
            verify=CLIENT_TLS,
            # Idle connections are dropped well before the services close them (30 s).
            limits=httpx.Limits(keepalive_expiry=5.0),
        )

    async def aclose(self) -> None:
        await self.http.aclose()

    def _target(self, prefix: str) -> tuple[str, str] | None:
        return self.routes.get(prefix)

    async def forward(self, request: Request, prefix: str, path: str) -> Response:
        received = stamp()
        target = self._target(prefix)
        if target is None:
            return error_response(404, "not_found", f"no service serves /api/{prefix}")
        service, base = target
        try:
            path = below_prefix(request.scope["path"], prefix)
            url = f"{base}/{prefix}" + (f"/{service_path(path)}" if path else "")
        except PathRefused:
            return error_response(400, "bad_path", BAD_PATH)
        headers = {**forwarded_headers(request), **identity_headers(request)}
        # When the request reached the runtime (a client's own value is replaced): services
        # that promise a reaction time count from here, e.g. a program stop.
        headers[REQUEST_START] = received
        body = await request.body()
        start, wait = float(received), deadline.GATEWAY_TIMEOUT
        if request.scope["path"].startswith(tuple(UPLOADS)):
            # A file: its transfer from a tablet does not count against the service's time,
            # and the service has longer to check it.
            start, wait = time.time(), UPLOAD_TIMEOUT
        # Given up on at the timeout below (504): the service must not apply it later.
        headers[deadline.HEADER] = deadline.for_request(start, wait)
        try:
            upstream = await self.http.request(
                request.method,
                url,
                params=request.query_params,
                headers=headers,
                content=body,
                timeout=httpx.Timeout(wait, connect=2.0),
            )
        except httpx.TimeoutException:
            return error_response(504, "service_timeout", f"{service} did not answer in time")
        except httpx.TransportError:
            return error_response(503, "service_unavailable", f"{service} is not responding")
        kept = {k: v for k, v in upstream.headers.items() if k.lower() in _KEEP_RESPONSE}
        return Response(upstream.content, status_code=upstream.status_code, headers=kept)

    async def forward_ws(self, ws: WebSocket, prefix: str, path: str) -> None:
        target = self._target(prefix)
        await ws.accept()
        if target is None:
            await _close_with_error(ws, "not_found", f"no service serves /api/{prefix}")
            return
        service, base = target
        query = f"?{ws.url.query}" if ws.url.query else ""
        try:
            below = service_path(below_prefix(ws.scope["path"], prefix))
        except PathRefused:
            await _close_with_error(ws, "bad_path", BAD_PATH)
            return
        url = base.replace("http://", "ws://", 1) + f"/{prefix}/{below}{query}"
        try:
            upstream = await websockets.connect(
                url,
                open_timeout=2.0,
                close_timeout=1.0,
                max_size=2**24,
                additional_headers={**internal_headers(LOOPBACK), **identity_headers(ws)},
            )
        except (OSError, websockets.WebSocketException, TimeoutError):
            await _close_with_error(ws, "service_unavailable", f"{service} is not responding")
            return
        async with upstream:
            await _pipe(ws, upstream)


async def _pipe(client: WebSocket, upstream: websockets.ClientConnection) -> None:
    async def down() -> None:
        async for message in upstream:
            if isinstance(message, str):
                await client.send_text(message)
            else:
                await client.send_bytes(message)

    async def up() -> None:
        while True:
            message = await client.receive()
            if message["type"] == "websocket.disconnect":
                return
            if message.get("text") is not None:
                await upstream.send(message["text"])
            elif message.get("bytes") is not None:
                await upstream.send(message["bytes"])

    await until_either_ends(client, down(), up(), expected=(websockets.WebSocketException,))


async def _close_with_error(ws: WebSocket, code: str, message: str) -> None:
    with contextlib.suppress(RuntimeError, OSError, WebSocketDisconnect):
        await ws.send_text(
            json.dumps({"type": "error", "error": {"code": code, "message": message}})
        )
        await ws.close(code=1011)
