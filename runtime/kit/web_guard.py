"""What a browser may do with the runtime's public ports (the UI's and the jog socket's): one
ASGI middleware in front of them.

- `Host` must name this computer (an IP literal, or a configured or local name): a page of
  another site whose name was re-pointed at this computer (DNS rebinding) sends its own name.
- An `Origin`, when a browser sends one, must be the UI's own (an allowed host at the UI's
  port): another site's page can neither change anything nor open a socket. Browsers send
  `Origin` with every cross-origin request that could change something and every WebSocket.
- A request body must be JSON (or YAML where an import takes it; a file's raw bytes only at
  the upload paths the policy names, each with its own size bound): the body types a page
  of another site can send without asking first (text/plain, forms) are refused.
- Bodies are bounded, and every answer tells the browser not to sniff, frame or inline.
"""

from __future__ import annotations

import ipaddress
import json
import socket
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cache
from urllib.parse import urlsplit

from starlette.types import ASGIApp, Message, Receive, Scope, Send

BODY_TYPES = frozenset({"application/json", "application/yaml", "application/x-yaml"})
BODY_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
# A file's raw bytes: not a type another site's page may send without a preflight it fails.
UPLOAD_TYPE = "application/octet-stream"

# Blockly styles its blocks inline and draws icons from data: URIs; nothing else is needed
# from anywhere but this origin (the jog socket's own port is added per answer).
CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; font-src 'self' data:; worker-src 'self' blob:; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)


@cache
def local_names() -> frozenset[str]:
    """This computer's own names, as a browser on the LAN may address it."""
    names = {"localhost"}
    hostname = socket.gethostname().lower()
    if hostname:
        names |= {hostname, f"{hostname}.local"}
    return frozenset(names)


def split_host(value: str) -> tuple[str, int | None]:
    """`host[:port]` of a Host header (IPv6 in brackets) → (host, port); ValueError if bad."""
    parsed = urlsplit(f"//{value}")
    host = parsed.hostname
    if not host:
        raise ValueError("no host")
    return host.lower(), parsed.port


def is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def same_host(origin_host: str, host_header: str | None) -> bool:
    """Whether an Origin names the host the request's Host names (addresses compared as
    addresses, names without case)."""
    try:
        named, _ = split_host(host_header or "")
    except ValueError:
        return False
    if is_ip(origin_host) and is_ip(named):
        return ipaddress.ip_address(origin_host) == ipaddress.ip_address(named)
    return origin_host.lower() == named.lower()


@dataclass(frozen=True)
class Refusal:
    status: int
    code: str
    message: str


@dataclass
class WebPolicy:
    """Who the public ports answer. `ui_port`: where the UI is served (its origin's port)."""

    ui_port: int
    allowed_hosts: Iterable[str] = ()
    max_body: int = 16 * 1024 * 1024
    jog_port: int | None = None
    # Path prefixes that take a file's raw bytes (PUT), and the largest each takes.
    uploads: dict[str, int] = field(default_factory=dict)
    # "https" when the UI is served over TLS: a page of the plain-HTTP origin is not the UI.
    scheme: str = "http"
    names: frozenset[str] = field(init=False)

    def __post_init__(self) -> None:
        self.names = local_names() | {h.lower() for h in self.allowed_hosts}

    def host_allowed(self, host: str) -> bool:
        # A rebinding page's requests carry its own domain name; an IP literal is never one.
        return is_ip(host) or host in self.names

    def check_host(self, value: str | None) -> Refusal | None:
        try:
            host, _ = split_host(value or "")
        except ValueError:
            return Refusal(400, "host_not_allowed", "the request names no valid Host")
        if not self.host_allowed(host):
            return Refusal(
                400,
                "host_not_allowed",
                f"this runtime does not answer to the name {host[:80]!r}; an administrator "
                "can add it to allowed_hosts",
            )
        return None

    def check_origin(self, value: str | None, host_header: str | None = None) -> Refusal | None:
        """A page's requests are accepted from the UI's own origin: the name or address the
        request itself was sent to (one this computer answers to), at the UI's port. A page of
        another computer's address, or of `localhost` on the tablet itself, is not the UI."""
        if value is None:
            return None  # not a browser's cross-origin request (scripts, same-origin GETs)
        parsed = urlsplit(value)
        try:
            port = parsed.port or {"http": 80, "https": 443}.get(parsed.scheme)
        except ValueError:
            port = None
        host = (parsed.hostname or "").lower()
        ours = self.host_allowed(host) and same_host(host, host_header)
        if parsed.scheme == self.scheme and ours and port == self.ui_port:
            return None
        return Refusal(
            403, "origin_not_allowed", f"requests from pages of {value[:80]!r} are not accepted"
        )

    def upload_limit(self, method: str, path: str) -> int | None:
        """The size bound of an upload path (None: not one)."""
        if method != "PUT":
            return None
        return next(
            (size for prefix, size in self.uploads.items() if path.startswith(prefix)), None
        )

    def check_body(self, method: str, headers: dict[str, str], path: str = "") -> Refusal | None:
        if method not in BODY_METHODS:
            return None
        media = headers.get("content-type", "").split(";", 1)[0].strip().lower()
        upload = self.upload_limit(method, path) if media == UPLOAD_TYPE else None
        limit = upload or self.max_body
        length = headers.get("content-length")
        chunked = "chunked" in headers.get("transfer-encoding", "").lower()
        if upload is not None and length is None:
            # Its length known first: a file is never read into memory before the sign-in
            # behind this guard has been checked.
            return Refusal(411, "length_required", "send the file with its Content-Length")
        if length is not None:
            try:
                size = int(length)
            except ValueError:
                return Refusal(400, "bad_request", "Content-Length is not a number")
            if size > limit:
                return self.too_large(limit)
            if size == 0 and not chunked:
                return None
        elif not chunked:
            return None
        if media in BODY_TYPES or media.endswith("+json") or upload is not None:
            return None
        return Refusal(
            415,
            "unsupported_media_type",
            f"send the body as application/json (got {media[:60] or 'no Content-Type'})",
        )

    def too_large(self, limit: int | None = None) -> Refusal:
        bound = limit or self.max_body
        return Refusal(413, "too_large", f"the request body is larger than {bound} bytes")

    def content_security_policy(self, host_header: str | None) -> str:
        if self.jog_port is None or not host_header:
            return CSP + "; connect-src 'self'"
        try:
            host, _ = split_host(host_header)
        except ValueError:
            return CSP + "; connect-src 'self'"
        if ":" in host:
            host = f"[{host}]"
        # Any port of this host: a restarted runtime may give the jog socket another port,
        # and a page loaded before keeps the policy it came with.
        sockets = f"wss://{host}:*" if self.scheme == "https" else f"ws://{host}:* wss://{host}:*"
        return CSP + f"; connect-src 'self' {sockets}"


def _headers(scope: Scope) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}


class WebGuard:
    def __init__(self, app: ASGIApp, policy: WebPolicy) -> None:
        self.app = app
        self.policy = policy

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = _headers(scope)
        refusal = self.policy.check_host(headers.get("host")) or self.policy.check_origin(
            headers.get("origin"), headers.get("host")
        )
        if scope["type"] == "websocket":
            if refusal is not None:
                # Closed before it is accepted: the browser sees a failed handshake (403).
                await send({"type": "websocket.close", "code": 1008, "reason": refusal.code})
                return
            await self.app(scope, receive, send)
            return
        refusal = refusal or self.policy.check_body(scope["method"], headers, scope["path"])
        send = self._with_headers(send, headers.get("host"))
        if refusal is not None:
            await _refuse(send, refusal)
            return
        if "content-length" not in headers and scope["method"] in BODY_METHODS:
            body = await self._read_chunked(receive)
            if body is None:
                await _refuse(send, self.policy.too_large())
                return
            receive = _replay(body, receive)
        await self.app(scope, receive, send)

    def _with_headers(self, send: Send, host: str | None) -> Send:
        extra = [
            (b"x-content-type-options", b"nosniff"),
            (b"x-frame-options", b"DENY"),
            (b"referrer-policy", b"same-origin"),
            (b"cross-origin-opener-policy", b"same-origin"),
            (
                b"content-security-policy",
                self.policy.content_security_policy(host).encode("latin-1"),
            ),
        ]

        async def sending(message: Message) -> None:
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), *extra]}
            await send(message)

        return sending

    async def _read_chunked(self, receive: Receive) -> bytes | None:
        """A body without a length, read whole before the app sees it (None: too large)."""
        body = bytearray()
        while True:
            message = await receive()
            if message["type"] != "http.request":
                return bytes(body)
            body += message.get("body", b"")
            if len(body) > self.policy.max_body:
                return None
            if not message.get("more_body", False):
                return bytes(body)


def _replay(body: bytes, receive: Receive) -> Receive:
    done = False

    async def receiving() -> Message:
        nonlocal done
        if done:
            return await receive()
        done = True
        return {"type": "http.request", "body": body, "more_body": False}

    return receiving


async def _refuse(send: Send, refusal: Refusal) -> None:
    body = json.dumps({"error": {"code": refusal.code, "message": refusal.message}}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": refusal.status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
