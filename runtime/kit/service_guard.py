"""What a service's ports answer. Its own port: the gateway and the other services (the
run's secret), and anyone's /health. Its public port (the jog socket's): a browser with a
ticket of a role that may use the path, once, while the sign-in it was given to stands."""

from __future__ import annotations

import asyncio
import contextlib
import json
from typing import Any
from urllib.parse import parse_qs

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.standing import SignIns
from openpendant.runtime.kit import tickets
from openpendant.runtime.kit.internal import HEADER, internal_token, is_internal
from openpendant.runtime.kit.sign_in_watch import ENDED, EndsWithSignIn
from openpendant.runtime.kit.words import Words

OPEN_PATHS = frozenset({"/health"})
# s between checks of an open jog socket's sign-in: it closes well within 2 s of its end.
RECHECK_EVERY = 0.5
USED = "this ticket was used already (a ticket opens one socket), or is older than this service"


async def deny(
    scope: Scope, receive: Receive, send: Send, status: int, code: str, message: str
) -> None:
    """As `refuse`, but a socket is answered with the HTTP status and the JSON error (where
    the server can: ASGI's websocket.http.response), so a client can tell why."""
    if scope["type"] == "websocket" and "websocket.http.response" in scope.get("extensions", {}):
        body = json.dumps({"error": {"code": code, "message": message}}).encode()
        headers = [(b"content-type", b"application/json"), (b"content-length", b"%d" % len(body))]
        await send({"type": "websocket.http.response.start", "status": status, "headers": headers})
        await send({"type": "websocket.http.response.body", "body": body})
        await _until_gone(receive)
        return
    await refuse(scope, receive, send, status, code, message)


# s a denial waits for the server to see its connection end.
GONE_WITHIN = 0.5


async def _until_gone(receive: Receive) -> None:
    """Returns once the server has seen the denied connection end. uvicorn's websockets-sansio
    protocol logs "ASGI callable returned without completing handshake" at ERROR for every
    denial whose app returns sooner (Kludex/uvicorn#3138): each refused jog ticket was an
    error in the jog service's log. It queues a disconnect as the denial goes out and another
    once the connection is closed (after the connect the app never read); a server that
    sends fewer is waited for at most GONE_WITHIN."""
    with contextlib.suppress(Exception):
        async with asyncio.timeout(GONE_WITHIN):
            disconnects = 0
            while disconnects < 2:
                disconnects += (await receive())["type"] == "websocket.disconnect"


async def refuse(
    scope: Scope,
    receive: Receive,
    send: Send,
    status: int,
    code: str,
    message: str,
    words: Words | None = None,
) -> None:
    if scope["type"] == "websocket":
        # Closed before it is accepted: nothing the socket would have carried is acted on.
        await send({"type": "websocket.close", "code": 1008, "reason": code})
        return
    error: dict[str, Any] = {"code": code, "message": message}
    if words is not None:
        error["words"] = words.body()
    await JSONResponse({"error": error}, status_code=status)(scope, receive, send)


def _header(scope: Scope, name: str) -> str | None:
    wanted = name.lower().encode()
    for key, value in scope.get("headers", []):
        if key.lower() == wanted:
            return bytes(value).decode("latin-1")
    return None


class InternalOnly:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app
        self.enforced = internal_token() is not None  # a service started by the launcher

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if (
            scope["type"] in ("http", "websocket")
            and self.enforced
            and scope.get("path") not in OPEN_PATHS
            and not is_internal(_header(scope, HEADER))
        ):
            await refuse(
                scope, receive, send, 403, "internal_only", "this port answers the runtime only"
            )
            return
        await self.app(scope, receive, send)


class TicketRequired:
    """A socket opened straight from a browser shows the ticket the gateway gave its user.
    A ticket opens one socket, and only while the sign-in it was given to stands; the socket
    closes (ENDED) within RECHECK_EVERY s of that sign-in's end, and what it drove halts as
    when a client goes. Its opening and closing, with the reason, go to the audit log under
    that user (the gateway, which audits everything else, does not see this port)."""

    def __init__(
        self,
        app: ASGIApp,
        role: int,
        sign_ins: SignIns,
        audit: AuditLog | None = None,
        every: float = RECHECK_EVERY,
    ) -> None:
        self.app = app
        self.role = role
        self.sign_ins = sign_ins
        self.audit = audit
        self.every = every
        self.redeemed = tickets.Redeemed()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        query = parse_qs(bytes(scope.get("query_string", b"")).decode("latin-1"))
        ticket = tickets.check(next(iter(query.get("ticket", [])), None))
        if ticket is None:
            await deny(
                scope, receive, send, 401, "unauthenticated", "sign in first (no valid ticket)"
            )
            return
        if not self.redeemed.take(ticket):
            await deny(scope, receive, send, 401, "ticket_used", USED)
            return
        standing = await asyncio.to_thread(self.sign_ins.standing, ticket)
        if standing.role is None:
            message = f"the sign-in this ticket was given to has ended ({standing.why})"
            await deny(scope, receive, send, 401, standing.why, message)
            return
        if standing.role < self.role:
            await deny(scope, receive, send, 403, "forbidden", "your role may not do this")
            return
        if scope["type"] == "websocket":
            await self._watched(scope, receive, send, ticket, standing.role)
            return
        await self.app(scope, receive, send)

    async def _ended(self, ticket: tickets.Ticket) -> str | None:
        standing = await asyncio.to_thread(self.sign_ins.standing, ticket)
        if standing.role is None:
            return standing.why
        return "role_changed" if standing.role < self.role else None

    async def _watched(
        self, scope: Scope, receive: Receive, send: Send, ticket: tickets.Ticket, role: Role
    ) -> None:
        watch = EndsWithSignIn(lambda: self._ended(ticket), self.every, receive, send)
        client = scope.get("client")
        entry = {
            "user": ticket.user,
            "role": role.name,
            "address": str(client[0]) if client else "",
            "target": scope["path"],
        }
        audit = self.audit
        opened = False

        async def sending(message: Message) -> None:
            nonlocal opened
            await watch.send(message)
            if message["type"] == "websocket.accept" and audit is not None:
                opened = True
                await asyncio.to_thread(audit.record, action="OPEN", status=101, **entry)

        try:
            await self.app(scope, watch.receive, sending)
        finally:
            await watch.stop()
            if opened and audit is not None:
                status, why = (ENDED, watch.why) if watch.why else (200, "closed")
                await asyncio.to_thread(
                    audit.record, action="CLOSE", status=status, detail={"why": why}, **entry
                )
