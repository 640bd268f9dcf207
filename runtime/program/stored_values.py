"""What a running program may keep in the variable storage (`store(name, value)`): plain
values of its own, under names that are only names, each small and all of a program's
together bounded. Programs, devices, tools, waypoints and frames are the user's: a program
reads them but never overwrites them."""

from __future__ import annotations

import json
from typing import Any

from runtime.interfaces.variables import NAME_PATTERN
from runtime.kit.errors import NotFound
from runtime.variable_storage.client import StorageClient
from sandbox.supervisor import CallRefused

MAX_VALUE_BYTES = 64 * 1024
MAX_PROGRAM_BYTES = 1024 * 1024
PROGRAM_TYPES = frozenset({"bool", "number", "string", "list", "json", "pose"})
RESERVED_PREFIXES = ("program.", "devices.", "tools.")


def checked_name(name: Any) -> str:
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise CallRefused(
            f"{str(name)[:40]!r} is not a variable name: start with a letter; letters, digits, "
            "'_', '.', '-' only; at most 128 characters",
            "invalid_name",
        )
    return name


def owner_tag(program: str) -> str:
    return f"stored-by:{program}"


def encoded_size(value: Any) -> int:
    try:
        return len(json.dumps(value, allow_nan=False, separators=(",", ":")).encode())
    except (TypeError, ValueError) as exc:
        raise CallRefused(f"this value cannot be stored: {exc}", "invalid_value") from None


async def put_value(storage: StorageClient, program: str, name: Any, kind: str, value: Any) -> None:
    name = checked_name(name)
    if kind not in PROGRAM_TYPES or name.startswith(RESERVED_PREFIXES):
        raise CallRefused(f"a program cannot store {name!r}: it is the user's", "reserved_name")
    size = encoded_size(value)
    if size > MAX_VALUE_BYTES:
        raise CallRefused(
            f"the value for {name} is {size} bytes; a stored value may have {MAX_VALUE_BYTES}",
            "too_large",
        )
    try:
        existing = await storage.get(name)
    except NotFound:
        existing = None
    if existing is not None and existing.type not in PROGRAM_TYPES:
        raise CallRefused(
            f"{name} is a {existing.type}; a program cannot overwrite it", "reserved_name"
        )
    tag = owner_tag(program)
    kept = await storage.query(tag=tag)
    total = size + sum(encoded_size(v.value) for v in kept if v.name != name)
    if total > MAX_PROGRAM_BYTES:
        raise CallRefused(
            f"{program} would keep {total} bytes in the variable storage; a program may keep "
            f"{MAX_PROGRAM_BYTES}",
            "storage_full",
        )
    tags = sorted({*(existing.tags if existing else []), tag})
    await storage.put(name, kind, value, tags=tags)
