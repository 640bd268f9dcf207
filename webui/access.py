"""Every request to /api and every socket, authenticated and authorised here, before the
gateway routes it anywhere: who it is (an API token, or a session cookie with its CSRF
token for anything that changes something), whether the role may (webui/policy.py), and an
audit entry for each change."""

from __future__ import annotations

from http.cookies import SimpleCookie
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.store import AuthStore, Identity
from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.service_guard import refuse
from openpendant.runtime.kit.sign_in_watch import ENDED, EndsWithSignIn
from openpendant.runtime.kit.words import Words, role_words, words
from openpendant.webui import policy
from openpendant.webui.proxy import BAD_PATH, PathRefused, service_path

SESSION_COOKIE = "op_session"
CSRF_HEADER = "x-csrf-token"
DOCS = ("/docs", "/redoc", "/openapi.json")
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
RECHECK_EVERY = 1.0  # s between re-checks of an open socket's session or token


def headers_of(scope: Scope) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}


def client_address(scope: Scope) -> str:
    # The peer of the connection: X-Forwarded-For and the like are a client's say-so.
    client = scope.get("client")
    return str(client[0]) if client else ""


def cookie_value(headers: dict[str, str], name: str) -> str | None:
    raw = headers.get("cookie")
    if not raw:
        return None
    jar: SimpleCookie = SimpleCookie()
    try:
        jar.load(raw)
    except Exception:  # a malformed cookie header is no session
        return None
    morsel = jar.get(name)
    return morsel.value if morsel is not None else None


def identify(store: AuthStore, headers: dict[str, str], *, touch: bool = True) -> Identity | None:
    authorization = headers.get("authorization", "")
    if authorization[:7].lower() == "bearer ":
        return store.token(authorization[7:].strip())
    secret = cookie_value(headers, SESSION_COOKIE)
    return store.session(secret, touch=touch) if secret else None


def need_of(scope: Scope) -> policy.Need | None:
    """None: not the API (the UI's files, /health) — served to anyone. `/metrics` (for the
    plant's monitoring) is any signed-in role's or token's to read."""
    path: str = scope["path"]
    method = scope.get("method", "WS") if scope["type"] == "http" else "WS"
    if path in DOCS or path.startswith("/docs/"):
        return Role.admin
    if path == "/api" or path.startswith("/api/"):
        return policy.need(method, path[4:] or "/")
    if path == "/metrics":
        return Role.viewer if method in SAFE_METHODS else Role.admin
    return None


class AccessGuard:
    def __init__(self, app: ASGIApp, store: AuthStore, audit: AuditLog) -> None:
        self.app = app
        self.store = store
        self.audit = audit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        need = need_of(scope)
        if need is None:
            await self.app(scope, receive, send)
            return
        try:
            service_path(scope["path"].lstrip("/"))
        except PathRefused:
            # Refused before the table is read: `..` must not make a path look like another.
            await refuse(scope, receive, send, 400, "bad_path", BAD_PATH)
            return
        if need == policy.INTERNAL:
            await refuse(scope, receive, send, 404, "not_found", "no such route")
            return
        headers = headers_of(scope)
        identity = identify(self.store, headers)
        scope.setdefault("state", {})["identity"] = identity
        if need != policy.PUBLIC:
            refusal = self._refusal(scope, headers, identity, need)
            if refusal is not None:
                await refuse(scope, receive, send, *refusal)
                return
        method = scope.get("method", "WS")
        watching = scope["type"] == "websocket" and not (
            isinstance(need, Role) and need >= Role.operator
        )
        # The sign-in routes record what they do themselves (with what the request cannot say).
        own_record = scope["path"].startswith("/api/auth/")
        if scope["type"] == "websocket" and identity is not None and isinstance(need, Role):
            await self._watched(scope, receive, send, headers, identity, need, watching)
            return
        if identity is None or method in SAFE_METHODS or watching or own_record:
            await self.app(scope, receive, send)
            return
        await self.app(scope, receive, self._audited(scope, send, identity))

    async def _watched(
        self,
        scope: Scope,
        receive: Receive,
        send: Send,
        headers: dict[str, str],
        who: Identity,
        need: Role,
        watching: bool,
    ) -> None:
        """A socket lives only as long as what opened it: a sign-out, a new password, a
        lower role, a revoked token or an expired session closes it (ENDED) within
        RECHECK_EVERY s, however busy it is, and the app behind sees the client leave."""

        async def ended() -> str | None:
            now = identify(self.store, headers, touch=False)
            if now is None:
                return "token_revoked" if who.via == "token" else "session_ended"
            return "role_changed" if now.role < need else None

        socket = EndsWithSignIn(ended, RECHECK_EVERY, receive, send)
        try:
            sending = socket.send if watching else self._audited(scope, socket.send, who)
            await self.app(scope, socket.receive, sending)
        finally:
            await socket.stop()
            if socket.why is not None:
                self._record(scope, who, "CLOSE", ENDED, {"why": socket.why})

    def _refusal(
        self, scope: Scope, headers: dict[str, str], who: Identity | None, need: policy.Need
    ) -> tuple[int, str, str, Words] | None:
        if who is None:
            return self._signed_out(headers)
        if isinstance(need, Role) and who.role < need:
            return (
                403,
                "forbidden",
                f"{_a(who.role.name)} may not do this ({_a(need.name)} may)",
                words("access.role", role=role_words(who.role.name), need=role_words(need.name)),
            )
        method = scope.get("method", "WS")
        if who.via == "session" and scope["type"] == "http" and method not in SAFE_METHODS:
            sent = headers.get(CSRF_HEADER, "")
            if not who.csrf or not same_secret(sent, who.csrf):
                message = "the request lacks this session's CSRF token"
                return 403, "csrf_failed", message, words("access.csrf")
        return None

    def _signed_out(self, headers: dict[str, str]) -> tuple[int, str, str, Words]:
        """401, saying why where this tablet's session ended lately (the sign-in screen
        tells the operator: expired, signed out, a new role or password, removed)."""
        secret = cookie_value(headers, SESSION_COOKIE)
        why = self.store.ended(secret) if secret else None
        if why is None:
            return 401, "unauthenticated", "sign in first", words("access.sign_in")
        message = f"sign in again: this session ended ({why.replace('_', ' ')})"
        return (
            401,
            "session_ended",
            message,
            words("access.session_ended", why=words(f"session.{why}")),
        )

    def _audited(self, scope: Scope, send: Send, who: Identity) -> Send:
        status = 0

        async def sending(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = int(message["status"])
            await send(message)
            if message["type"] == "http.response.body" and not message.get("more_body"):
                self._record(scope, who, scope.get("method", "WS"), status)
            elif message["type"] == "websocket.accept":
                self._record(scope, who, "OPEN", 101)

        return sending

    def _record(
        self,
        scope: Scope,
        who: Identity,
        action: str,
        status: int,
        detail: dict[str, Any] | None = None,
    ) -> None:
        self.audit.record(
            user=who.user,
            role=who.role.name,
            address=client_address(scope),
            action=action,
            target=scope["path"],
            status=status,
            detail=detail,
        )


def _a(role: str) -> str:
    """The role with its article: "an operator", "a viewer"."""
    return f"{'an' if role[:1] in 'aeiou' else 'a'} {role}"
