"""The runtime's services answer only the gateway and each other: every request between
them carries the launcher's secret for this run (tests read it from the data directory,
as any process of the runtime computer's owner could). A browser's request never has it,
so a page cannot reach a service's port even on the runtime computer itself."""

from __future__ import annotations

import hashlib
import os
from functools import cache
from urllib.parse import urlsplit

from openpendant.runtime.kit.constant_time import same_secret
from openpendant.runtime.kit.settings import is_loopback

ENV = "OPENPENDANT_INTERNAL_TOKEN"
HEADER = "X-OpenPendant-Internal"
FILE = "internal-token"


@cache
def internal_token() -> str | None:
    return os.environ.get(ENV) or None


def internal_headers(url: str) -> dict[str, str]:
    """The secret, for a service's URL only (never to a device on the network)."""
    token = internal_token()
    if token is None or not is_loopback(urlsplit(url).hostname or ""):
        return {}
    return {HEADER: token}


def is_internal(value: str | None) -> bool:
    token = internal_token()
    return token is not None and value is not None and same_secret(value, token)


def derived_key(purpose: str) -> bytes:
    """A key of its own for each use of the secret (e.g. signing jog-socket tickets)."""
    token = internal_token() or ""
    return hashlib.sha256(f"{purpose}:{token}".encode()).digest()
