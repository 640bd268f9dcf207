"""Comparing secrets in constant time, whatever a client sent.

`hmac.compare_digest` raises TypeError on a str holding non-ASCII characters; a header or a
JSON field from a client may hold any, and must be a refusal, not a 500."""

from __future__ import annotations

import hmac


def _bytes(value: str | bytes) -> bytes:
    return value if isinstance(value, bytes) else value.encode("utf-8", "surrogatepass")


def same_secret(given: str | bytes, expected: str | bytes) -> bool:
    return hmac.compare_digest(_bytes(given), _bytes(expected))
