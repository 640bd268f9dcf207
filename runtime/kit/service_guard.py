"""What a service's ports answer. Its own port: the gateway and the other services (the
run's secret), and anyone's /health. Its public port (the jog socket's): a browser with a
ticket of a role that may use the path."""

from __future__ import annotations

import asyncio
from urllib.parse import parse_qs

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from runtime.auth.audit import AuditLog
from runtime.auth.roles import Role
from runtime.kit import tickets
from runtime.kit.internal import HEADER, internal_token, is_internal

OPEN_PATHS = frozenset({"/health"})


async def refuse(
    scope: Scope, receive: Receive, send: Send, status: int, code: str, message: str
) -> None:
    if scope["type"] == "websocket":
        # Closed before it is accepted: nothing the socket would have carried is acted on.
        await send({"type": "websocket.close", "code": 1008, "reason": code})
        return
    body = {"error": {"code": code, "message": message}}
    await JSONResponse(body, status_code=status)(scope, receive, send)


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
    """A socket opened straight from a browser shows the ticket the gateway gave its user;
    its opening and closing go to the audit log under that user (the gateway, which audits
    everything else, does not see this port)."""

    def __init__(self, app: ASGIApp, role: int, audit: AuditLog | None = None) -> None:
        self.app = app
        self.role = role
        self.audit = audit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] in ("http", "websocket"):
            query = parse_qs(bytes(scope.get("query_string", b"")).decode("latin-1"))
            holder = tickets.check(next(iter(query.get("ticket", [])), None))
            if holder is None:
                await refuse(
                    scope, receive, send, 401, "unauthenticated", "sign in first (no valid ticket)"
                )
                return
            if holder[1] < self.role:
                await refuse(scope, receive, send, 403, "forbidden", "your role may not do this")
                return
            if scope["type"] == "websocket" and self.audit is not None:
                await self._audited(scope, receive, send, *holder)
                return
        await self.app(scope, receive, send)

    async def _audited(
        self, scope: Scope, receive: Receive, send: Send, user: str, role: int
    ) -> None:
        audit = self.audit
        assert audit is not None
        client = scope.get("client")
        entry = {
            "user": user,
            "role": Role(role).name,
            "address": str(client[0]) if client else "",
            "target": scope["path"],
        }
        opened = False

        async def sending(message: Message) -> None:
            nonlocal opened
            await send(message)
            if message["type"] == "websocket.accept":
                opened = True
                await asyncio.to_thread(audit.record, action="OPEN", status=101, **entry)

        try:
            await self.app(scope, receive, sending)
        finally:
            if opened:
                await asyncio.to_thread(audit.record, action="CLOSE", status=200, **entry)
