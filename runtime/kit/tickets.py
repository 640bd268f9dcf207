"""Short-lived tickets the gateway gives a signed-in user for a socket it does not carry
itself (the jog socket's own port): who, which role, until when, and the sign-in that asked
for it (a session or an API token), signed with a key only the runtime's processes have.

A ticket opens one socket: the service that takes it remembers it until it expires, and
refuses any ticket issued before the service started (it remembers nothing from before).
The socket lives only as long as the sign-in named in the ticket."""

from __future__ import annotations

import base64
import hashlib
import hmac
import json
import secrets
import time
from dataclasses import dataclass
from typing import Literal

from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.internal import derived_key

LIFETIME = 60.0  # s to open the socket with it

SignInKind = Literal["session", "token"]


@dataclass(frozen=True)
class Ticket:
    id: str
    user: str
    role: int
    kind: SignInKind
    sign_in: str  # the session's id digest, or the API token's id
    issued: float
    expires: float


def _sign(payload: bytes) -> str:
    return hmac.new(derived_key("ticket"), payload, hashlib.sha256).hexdigest()


def issue(
    user: str,
    role: int,
    *,
    session: str | None = None,
    token: str | None = None,
    now: float | None = None,
) -> str:
    """A ticket for the sign-in that asks: its session (id digest) or its API token (id)."""
    if (session is None) == (token is None):
        raise ValueError("a ticket is bound to one session or one API token")
    issued = time.time() if now is None else now
    kind, sign_in = ("session", session) if session is not None else ("token", token)
    body = {
        "n": secrets.token_urlsafe(12),
        "u": user,
        "r": role,
        "k": kind,
        "s": sign_in,
        "i": issued,
        "e": issued + LIFETIME,
    }
    payload = base64.urlsafe_b64encode(json.dumps(body).encode()).decode()
    return f"{payload}.{_sign(payload.encode())}"


def check(ticket: str | None, now: float | None = None) -> Ticket | None:
    """The ticket, if it is signed by this run and not expired; else None."""
    if not ticket or not ticket.isascii() or ticket.count(".") != 1:
        return None
    payload, signature = ticket.split(".")
    if not same_secret(signature, _sign(payload.encode())):
        return None
    try:
        data = json.loads(base64.urlsafe_b64decode(payload.encode()))
        kind = str(data["k"])
        if kind not in ("session", "token"):
            return None
        found = Ticket(
            id=str(data["n"]),
            user=str(data["u"]),
            role=int(data["r"]),
            kind="session" if kind == "session" else "token",
            sign_in=str(data["s"]),
            issued=float(data["i"]),
            expires=float(data["e"]),
        )
    except (ValueError, KeyError, TypeError):
        return None
    if found.expires < (time.time() if now is None else now):
        return None
    return found


class Redeemed:
    """The tickets a service has taken. In memory: a restarted service refuses every ticket
    issued before it started, so none can open a second socket across a restart."""

    def __init__(self, started: float | None = None) -> None:
        self.started = time.time() if started is None else started
        self._used: dict[str, float] = {}  # ticket id -> when it expires

    def take(self, ticket: Ticket, now: float | None = None) -> bool:
        """True the first time a ticket is shown; False after, or if it predates us."""
        now = time.time() if now is None else now
        if ticket.issued < self.started or ticket.expires < now:
            return False
        for old in [k for k, expires in self._used.items() if expires < now]:
            del self._used[old]
        if ticket.id in self._used:
            return False
        self._used[ticket.id] = ticket.expires
        return True
