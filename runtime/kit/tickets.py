"""Short-lived tickets the gateway gives a signed-in user for a socket it does not carry
itself (the jog socket's own port): who, which role, until when, signed with a key only
the runtime's processes have."""

from __future__ import annotations

import base64
import hashlib
import hmac
import json
import time

from runtime.kit.constant_time import same_secret
from runtime.kit.internal import derived_key

LIFETIME = 60.0  # s to open the socket with it


def _sign(payload: bytes) -> str:
    return hmac.new(derived_key("ticket"), payload, hashlib.sha256).hexdigest()


def issue(user: str, role: int, now: float | None = None) -> str:
    expires = (now or time.time()) + LIFETIME
    payload = base64.urlsafe_b64encode(
        json.dumps({"u": user, "r": role, "e": expires}).encode()
    ).decode()
    return f"{payload}.{_sign(payload.encode())}"


def check(ticket: str | None, now: float | None = None) -> tuple[str, int] | None:
    """(user, role) of a valid ticket, else None."""
    if not ticket or not ticket.isascii() or ticket.count(".") != 1:
        return None
    payload, signature = ticket.split(".")
    if not same_secret(signature, _sign(payload.encode())):
        return None
    try:
        data = json.loads(base64.urlsafe_b64decode(payload.encode()))
        user, role, expires = str(data["u"]), int(data["r"]), float(data["e"])
    except (ValueError, KeyError, TypeError):
        return None
    if expires < (now or time.time()):
        return None
    return user, role
