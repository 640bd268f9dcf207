"""A driver obeys only the runtime it is paired with (runtime/kit/device_auth.py): every
request that changes something and every socket but the state stream must be signed with
the device's secret. What it is and how it is (info, state, the command log) stays readable.
Its proof of pairing covers the address the challenge reached it at: passed on by another
host, it proves nothing for that host's address. Every answer names this process's boot id,
for which signatures are made: one made before a restart is refused after it."""

from __future__ import annotations

import asyncio
from urllib.parse import parse_qs

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.device_auth import (
    BOOT_HEADER,
    EMPTY_BODY,
    HEADER,
    PROOF_PATH,
    Verifier,
    address_text,
    body_digest,
    new_boot,
    proof,
)
from openpendant.runtime.kit.service_guard import refuse

OPEN_SOCKETS = frozenset({"/state/ws"})
# A simulator's hooks into the world around its device (an E-stop pressed, a part taken, a
# recorded 3D mouse played, the arm set where a test starts): what a person in the cell
# does, not what the runtime commands. A real driver has none.
WORLD_PREFIXES = ("/sim/", "/replay/")
READS = frozenset({"GET", "HEAD"})
# A signed request's body is read whole to check its digest: no command is near this size.
MAX_SIGNED_BODY = 32 * 1024 * 1024
BODY_SECONDS = 10.0  # a body that takes longer is not the runtime's
# Messages that open an answer, to which the boot id is added.
ANSWERS = frozenset({"http.response.start", "websocket.http.response.start", "websocket.accept"})


def _header(scope: Scope) -> str | None:
    wanted = HEADER.lower().encode()
    for key, value in scope.get("headers", []):
        if key.lower() == wanted:
            return bytes(value).decode("latin-1")
    return None


class BodyRefused(Exception):
    def __init__(self, status: int, code: str, message: str) -> None:
        self.status, self.code, self.message = status, code, message


async def read_body(receive: Receive) -> bytes | None:
    """A request's whole body (within MAX_SIGNED_BODY and BODY_SECONDS); None if the
    client left."""
    body = bytearray()
    try:
        async with asyncio.timeout(BODY_SECONDS):
            while True:
                message = await receive()
                if message["type"] != "http.request":
                    return None
                body += message.get("body", b"")
                if len(body) > MAX_SIGNED_BODY:
                    raise BodyRefused(413, "body_too_large", "a command's body is under 32 MiB")
                if not message.get("more_body", False):
                    return bytes(body)
    except TimeoutError:
        raise BodyRefused(408, "body_timeout", "the command's body did not arrive") from None


def replaying(body: bytes, receive: Receive) -> Receive:
    """`receive` for an app after the body has been read: the body, then what follows."""
    given = False

    async def again() -> Message:
        nonlocal given
        if not given:
            given = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return again


class CommandGuard:
    def __init__(self, app: ASGIApp, secret: str) -> None:
        self.app = app
        self.secret = secret
        self.boot = new_boot()
        self.verifier = Verifier(secret, self.boot)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        boot = (BOOT_HEADER.lower().encode(), self.boot.encode())

        async def naming_boot(message: Message) -> None:
            if message["type"] in ANSWERS:
                message = {**message, "headers": [*message.get("headers", []), boot]}
            await send(message)

        await self._guard(scope, receive, naming_boot)

    async def _guard(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind == "http" and scope["path"] == PROOF_PATH:
            query = parse_qs(bytes(scope.get("query_string", b"")).decode("latin-1"))
            nonce = next(iter(query.get("nonce", [])), "")
            if not 16 <= len(nonce) <= 128:
                message = "give a nonce of 16-128 characters"
                await refuse(scope, receive, send, 422, "bad_nonce", message)
                return
            # The local end of this connection: the address the challenger reached.
            server = scope.get("server")
            if not server:
                message = "this device cannot tell the address it was reached at"
                await refuse(scope, receive, send, 409, "no_address", message)
                return
            address = address_text(str(server[0]), int(server[1]))
            answer = {"proof": proof(self.secret, nonce, address), "address": address}
            await JSONResponse(answer)(scope, receive, send)
            return
        world = str(scope.get("path", "")).startswith(WORLD_PREFIXES)
        guarded = not world and (
            (kind == "http" and scope["method"] not in READS)
            or (kind == "websocket" and scope["path"] not in OPEN_SOCKETS)
        )
        method = scope.get("method", "GET")
        if guarded:
            # The header first: only this device's runtime can make it read a body.
            digest = self.verifier.check_header(_header(scope), method, scope["path"])
            if digest is not None and kind == "http":
                try:
                    body = await read_body(receive)
                except BodyRefused as refused:
                    await refuse(
                        scope, receive, send, refused.status, refused.code, refused.message
                    )
                    return
                if body is None:
                    return  # the client left
                receive = replaying(body, receive)
                genuine = same_secret(digest, body_digest(body))
            else:
                genuine = digest is not None and digest == EMPTY_BODY
            if not genuine:
                await refuse(
                    scope,
                    receive,
                    send,
                    401,
                    "device_auth",
                    "this device obeys only the runtime it is paired with",
                )
                return
        await self.app(scope, receive, send)
