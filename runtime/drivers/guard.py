"""A driver obeys only the runtime it is paired with (runtime/kit/device_auth.py): every
request that changes something and every socket but the state stream must be signed with
the device's secret. What it is and how it is (info, state, the command log) stays readable.
Its proof of pairing covers the address the challenge reached it at: passed on by another
host, it proves nothing for that host's address."""

from __future__ import annotations

from urllib.parse import parse_qs

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Receive, Scope, Send

from openpendant.runtime.kit.device_auth import HEADER, PROOF_PATH, Verifier, address_text, proof
from openpendant.runtime.kit.service_guard import refuse

OPEN_SOCKETS = frozenset({"/state/ws"})
# A simulator's hooks into the world around its device (an E-stop pressed, a part taken, a
# recorded 3D mouse played, the arm set where a test starts): what a person in the cell
# does, not what the runtime commands. A real driver has none.
WORLD_PREFIXES = ("/sim/", "/replay/")
READS = frozenset({"GET", "HEAD"})


def _header(scope: Scope) -> str | None:
    wanted = HEADER.lower().encode()
    for key, value in scope.get("headers", []):
        if key.lower() == wanted:
            return bytes(value).decode("latin-1")
    return None


class CommandGuard:
    def __init__(self, app: ASGIApp, secret: str) -> None:
        self.app = app
        self.secret = secret
        self.verifier = Verifier(secret)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
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
        if guarded and not self.verifier.check(_header(scope), method, scope["path"]):
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
