"""/api/auth: the set-up screen's first administrator, signing in and out (password, or an
operator's PIN on a shared tablet), one's own password, and the administrator's users, API
tokens and audit log. Changes to users and credentials ask for the password again."""

from __future__ import annotations

import asyncio
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Request, Response
from pydantic import BaseModel, Field

from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.store import AuthStore, Identity, LockedOut, Unauthenticated
from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.kit import tickets
from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.errors import InvalidValue, OpenPendantError
from openpendant.runtime.kit.settings import is_loopback
from openpendant.runtime.kit.tls import CA_DOWNLOAD, TlsFiles
from openpendant.webui import policy
from openpendant.webui.access import SESSION_COOKIE, client_address

RoleName = Literal["viewer", "operator", "programmer", "admin"]
Text = Annotated[str, Field(min_length=1, max_length=256)]


class Forbidden(OpenPendantError):
    status = 403
    code = "forbidden"


class Login(Strict):
    user: Text
    password: Text


class PinLogin(Strict):
    user: Text
    pin: Annotated[str, Field(min_length=4, max_length=8)]


class Setup(Strict):
    user: Text
    password: Text
    code: str | None = Field(default=None, max_length=64)


class PasswordChange(Strict):
    current: Text
    new: Text


class NewUser(Strict):
    name: Text
    role: RoleName
    password: Text
    confirm_password: Text  # the administrator's own


class UserChange(Strict):
    role: RoleName | None = None
    password: Text | None = None
    pin: Annotated[str, Field(max_length=8)] | None = None  # "" removes it
    confirm_password: Text


class Confirmation(Strict):
    confirm_password: Text


class NewToken(Strict):
    name: Annotated[str, Field(min_length=1, max_length=64)]
    role: RoleName
    confirm_password: Text


# What the routes answer (the UI's client is generated from these, webui/openapi.py).


class TlsStatus(BaseModel):
    """What a tablet checks before it trusts the UI's HTTPS (nothing of it is secret)."""

    fingerprint: str  # SHA-256 of the runtime's certificate authority, or the site's certificate
    authority: bool  # the runtime's own authority, which a tablet installs from `download`
    download: str | None
    lan_download: str | None = None  # the same from the LAN (for a QR code shown on loopback)


class AuthStatus(BaseModel):
    set_up: bool  # an administrator exists
    setup_needs_code: bool  # from here, set-up asks for the code printed at start
    signed_in: bool
    tls: TlsStatus | None = None  # the UI is served over HTTPS


class SignedIn(BaseModel):
    user: str
    role: RoleName
    csrf: str | None  # shown on every changing request of the session (none for a token)


class Me(SignedIn):
    via: Literal["session", "token"]


Need = Literal["viewer", "operator", "programmer", "admin", "public", "internal"]


class PolicyRule(BaseModel):
    methods: list[str]
    pattern: str  # as JavaScript's RegExp reads it
    need: Need


class Policy(BaseModel):
    rules: list[PolicyRule]
    roles: list[RoleName]  # from least to most
    otherwise: Need


class Ticket(BaseModel):
    ticket: str
    lifetime: float  # s


class UserRow(BaseModel):
    name: str
    role: RoleName
    created: float
    has_pin: bool
    locked_until: float


class UserRole(BaseModel):
    name: str
    role: RoleName


class TokenRow(BaseModel):
    id: str
    name: str
    role: RoleName
    created: float
    last_used: float | None


class TokenMade(BaseModel):
    token: str  # shown in this answer only
    name: str
    role: RoleName


class AuditRow(BaseModel):
    seq: int
    ts: float
    user: str
    role: str  # "" for a failed sign-in
    address: str
    action: str
    target: str
    status: int
    detail: dict[str, Any]


def identity(request: Request) -> Identity:
    who: Identity | None = request.scope.get("state", {}).get("identity")
    if who is None:
        raise Unauthenticated("sign in first")
    return who


def auth_router(
    store: AuthStore,
    audit: AuditLog,
    setup_code: str | None,
    tls: TlsFiles | None = None,
    lan_download: str | None = None,
) -> APIRouter:
    router = APIRouter(prefix="/api/auth")
    tls_status = (
        None
        if tls is None
        else TlsStatus(
            fingerprint=tls.fingerprint(),
            authority=tls.ca is not None,
            download=CA_DOWNLOAD if tls.ca is not None else None,
            lan_download=lan_download if tls.ca is not None else None,
        )
    )

    def record(
        request: Request,
        user: str,
        role: str,
        action: str,
        status: int,
        detail: dict[str, Any] | None = None,
    ) -> None:
        audit.record(
            user=user,
            role=role,
            address=client_address(request.scope),
            action=action,
            target=request.url.path,
            status=status,
            detail=detail,
        )

    def signed_in(request: Request, response: Response, user: str, role: Role) -> SignedIn:
        secret, csrf = store.open_session(user)
        response.set_cookie(
            SESSION_COOKIE,
            secret,
            httponly=True,
            samesite="strict",
            secure=request.url.scheme == "https",
            path="/",
        )
        return SignedIn(user=user, role=role.name, csrf=csrf)

    async def check(request: Request, user: str, secret: str, *, pin: bool = False) -> Role:
        try:
            role = await asyncio.to_thread(store.verify, user, secret, pin=pin)
        except (Unauthenticated, LockedOut) as exc:
            record(request, user, "", "LOGIN", exc.status, {"why": exc.code, "pin": pin})
            raise
        return role

    async def reauthenticated(request: Request, password: str) -> Identity:
        who = identity(request)
        if who.via != "session":
            raise Forbidden("changes to users and credentials are made signed in, not by token")
        await check(request, who.user, password)
        return who

    @router.get("/status")
    async def status(request: Request) -> AuthStatus:
        """What the sign-in screen shows: set-up still to do, and whether from here."""
        who = request.scope.get("state", {}).get("identity")
        return AuthStatus(
            set_up=store.user_count() > 0,
            setup_needs_code=not is_loopback(client_address(request.scope)),
            signed_in=who is not None,
            tls=tls_status,
        )

    @router.post("/setup")
    async def setup(body: Setup, request: Request, response: Response) -> SignedIn:
        """The first administrator: from the runtime computer itself, or with the one-time
        code the runtime printed where it was started."""
        local = is_loopback(client_address(request.scope))
        code_ok = setup_code is not None and same_secret(body.code or "", setup_code)
        if not (local or code_ok):
            raise Forbidden(
                "set up from the runtime computer, or give the code it printed at start",
                code="setup_code_needed",
            )
        await asyncio.to_thread(store.create_user, body.user, body.password, Role.admin, first=True)
        record(request, body.user, "admin", "SETUP", 200)
        return signed_in(request, response, body.user, Role.admin)

    @router.post("/login")
    async def login(body: Login, request: Request, response: Response) -> SignedIn:
        role = await check(request, body.user, body.password)
        record(request, body.user, role.name, "LOGIN", 200)
        return signed_in(request, response, body.user, role)

    @router.post("/pin")
    async def pin_login(body: PinLogin, request: Request, response: Response) -> SignedIn:
        """An operator's quick switch on a shared tablet; never more than an operator."""
        role = await check(request, body.user, body.pin, pin=True)
        if role > Role.operator:
            raise Forbidden("a PIN signs in operators and viewers only; use your password")
        record(request, body.user, role.name, "LOGIN", 200, {"pin": True})
        return signed_in(request, response, body.user, role)

    @router.post("/logout", status_code=204)
    async def logout(request: Request, response: Response) -> Response:
        who = identity(request)
        if who.session is not None:
            store.close_session(who.session)
        record(request, who.user, who.role.name, "LOGOUT", 204)
        response = Response(status_code=204)
        response.delete_cookie(SESSION_COOKIE, path="/")
        return response

    @router.get("/me")
    async def me(request: Request) -> Me:
        who = identity(request)
        return Me.model_validate(
            {"user": who.user, "role": who.role.name, "csrf": who.csrf, "via": who.via}
        )

    @router.get("/policy")
    async def rights() -> Policy:
        """The table of rights this gateway enforces, for the UI to disable what the role
        signed in may not do: the rules in order (the first that matches a method and a path
        below /api decides), the roles from least to most, and the need of a request no
        rule names."""
        return Policy.model_validate(
            {
                "rules": policy.served(),
                "roles": [role.name for role in Role],
                "otherwise": policy.ADMIN.name,
            }
        )

    @router.post("/me/password")
    async def change_password(
        body: PasswordChange, request: Request, response: Response
    ) -> SignedIn:
        """Every session of the user ends; this one goes on with a new session."""
        who = await reauthenticated(request, body.current)
        await asyncio.to_thread(store.set_password, who.user, body.new)
        record(request, who.user, who.role.name, "PASSWORD", 200)
        return signed_in(request, response, who.user, who.role)

    @router.post("/ticket")
    async def ticket(request: Request) -> Ticket:
        """A ticket to open one jog socket on its own port (within a minute); the socket
        closes when this session ends or this token is revoked."""
        who = identity(request)
        ticket = tickets.issue(who.user, int(who.role), session=who.session, token=who.token)
        return Ticket(ticket=ticket, lifetime=tickets.LIFETIME)

    @router.get("/users")
    async def users() -> list[UserRow]:
        return [UserRow.model_validate(u.__dict__) for u in store.users()]

    @router.post("/users", status_code=201)
    async def add_user(body: NewUser, request: Request) -> UserRole:
        who = await reauthenticated(request, body.confirm_password)
        role = Role.named(body.role)
        await asyncio.to_thread(store.create_user, body.name, body.password, role)
        detail = {"name": body.name, "role": role.name}
        record(request, who.user, who.role.name, "ADD_USER", 201, detail)
        return UserRole.model_validate({"name": body.name, "role": role.name})

    @router.put("/users/{name}")
    async def change_user(name: str, body: UserChange, request: Request) -> UserRole:
        who = await reauthenticated(request, body.confirm_password)
        before = store.role_of(name)
        if body.role is not None:
            store.set_role(name, Role.named(body.role))
        if body.password is not None:
            await asyncio.to_thread(store.set_password, name, body.password)
        if body.pin is not None:
            await asyncio.to_thread(store.set_pin, name, body.pin or None)
        after = store.role_of(name)
        record(
            request,
            who.user,
            who.role.name,
            "CHANGE_USER",
            200,
            {
                "name": name,
                "before": {"role": before.name},
                "after": {"role": after.name},
                "password": body.password is not None,
                "pin": body.pin is not None,
            },
        )
        return UserRole.model_validate({"name": name, "role": after.name})

    @router.delete("/users/{name}", status_code=204)
    async def delete_user(name: str, body: Confirmation, request: Request) -> Response:
        who = await reauthenticated(request, body.confirm_password)
        if name == who.user:
            raise InvalidValue("you cannot remove yourself", code="self")
        store.delete_user(name)
        record(request, who.user, who.role.name, "DELETE_USER", 204, {"name": name})
        return Response(status_code=204)

    @router.get("/tokens")
    async def tokens() -> list[TokenRow]:
        return [TokenRow.model_validate(t.__dict__) for t in store.tokens()]

    @router.post("/tokens", status_code=201)
    async def add_token(body: NewToken, request: Request) -> TokenMade:
        """The token is shown in this answer only."""
        who = await reauthenticated(request, body.confirm_password)
        secret = store.create_token(body.name, Role.named(body.role))
        detail = {"name": body.name, "role": body.role}
        record(request, who.user, who.role.name, "ADD_TOKEN", 201, detail)
        return TokenMade(token=secret, name=body.name, role=body.role)

    @router.delete("/tokens/{token_id}", status_code=204)
    async def revoke_token(token_id: str, body: Confirmation, request: Request) -> Response:
        who = await reauthenticated(request, body.confirm_password)
        store.revoke_token(token_id)
        record(request, who.user, who.role.name, "REVOKE_TOKEN", 204, {"token": token_id})
        return Response(status_code=204)

    @router.get("/audit")
    async def audit_entries(
        before: int | None = Query(None, ge=1, le=2**53), limit: int = Query(100, ge=1, le=1000)
    ) -> list[AuditRow]:
        entries = await asyncio.to_thread(audit.entries, before=before, limit=limit)
        return [AuditRow.model_validate(e.__dict__) for e in entries]

    @router.get("/audit/export")
    async def audit_export() -> Response:
        text = await asyncio.to_thread(audit.export_lines)
        return Response(
            text,
            media_type="application/x-ndjson",
            headers={"Content-Disposition": 'attachment; filename="openpendant-audit.jsonl"'},
        )

    return router
