"""What a running program may keep in the variable storage (`store(name, value)`): plain
values of its own, under names that are only names and outside the reserved namespaces,
each small and all of a program's together bounded. Programs, devices, tools, waypoints and
frames are the user's: a program reads them but never overwrites them.

The bound counts every version of a program's values that the store's history keeps, not
only the current ones: a program rewriting big values (or emptying them between writes)
grew the database by 37.8 MB of history in 8 s. The store knows which versions each
writer left and refuses, in the transaction of the write, one that would take them past
the budget; counting it here instead would race with the history's evictions."""

from __future__ import annotations

import json
from typing import Any

from openpendant.runtime.interfaces.variables import NAME_PATTERN
from openpendant.runtime.kit.errors import Conflict, NotFound
from openpendant.runtime.kit.words import words
from openpendant.runtime.program.reserved_names import refuse_reserved
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.sandbox.supervisor import CallRefused

MAX_VALUE_BYTES = 64 * 1024
MAX_PROGRAM_BYTES = 1024 * 1024
PROGRAM_TYPES = frozenset({"bool", "number", "string", "list", "json", "pose"})


def checked_name(name: Any) -> str:
    if not isinstance(name, str) or not NAME_PATTERN.match(name):
        raise CallRefused(
            f"{str(name)[:40]!r} is not a variable name: start with a letter; letters, digits, "
            "'_', '.', '-' only; at most 128 characters",
            "invalid_name",
            words("storage.bad_name", name=str(name)[:40]),
        )
    return name


def owner_tag(program: str) -> str:
    return f"stored-by:{program}"


def writer_of(program: str) -> str:
    return f"program:{program}"


def encoded_size(value: Any) -> int:
    try:
        return len(json.dumps(value, allow_nan=False, separators=(",", ":")).encode())
    except (TypeError, ValueError) as exc:
        raise CallRefused(f"this value cannot be stored: {exc}", "invalid_value") from None


async def put_value(storage: StorageClient, program: str, name: Any, kind: str, value: Any) -> None:
    name = checked_name(name)
    refuse_reserved(name)
    if kind not in PROGRAM_TYPES:
        raise CallRefused(
            f"a program cannot store {name!r}: it is the user's",
            "reserved_name",
            words("storage.users", name=name),
        )
    size = encoded_size(value)
    if size > MAX_VALUE_BYTES:
        raise CallRefused(
            f"the value for {name} is {size} bytes; a stored value may have {MAX_VALUE_BYTES}",
            "too_large",
            words("storage.too_large", name=name, size=size, limit=MAX_VALUE_BYTES),
        )
    try:
        existing = await storage.get(name)
    except NotFound:
        existing = None
    if existing is not None and existing.type not in PROGRAM_TYPES:
        raise CallRefused(
            f"{name} is a {existing.type}; a program cannot overwrite it",
            "reserved_name",
            words("storage.users", name=name),
        )
    tags = sorted({*(existing.tags if existing else []), owner_tag(program)})
    try:
        await storage.put(
            name, kind, value, tags=tags, writer=writer_of(program), budget=MAX_PROGRAM_BYTES
        )
    except Conflict as exc:
        if exc.code != "storage_full":
            raise
        raise CallRefused(
            f"{program} would keep {exc.details.get('bytes')} bytes in the variable storage: "
            f"{exc.details.get('versions')} versions of its values, the earlier ones the "
            f"history keeps included; a program may keep {MAX_PROGRAM_BYTES}. Store fewer, "
            "smaller or less often changed values",
            "storage_full",
            words(
                "storage.full",
                program=program,
                bytes=int(exc.details.get("bytes", 0)),
                budget=MAX_PROGRAM_BYTES,
            ),
        ) from None
