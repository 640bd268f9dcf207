"""The runtime's answers to the stored-variable blocks' calls (runtime/program/calls.py says how
they are written)."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.program.host import RunHost
from openpendant.runtime.program.stored_values import checked_name, put_value


async def get_stored(run: RunHost, args: dict[str, Any]) -> dict[str, Any]:
    variable = await run.storage.get(checked_name(args["name"]))
    return {"type": variable.type, "value": variable.value}


async def set_stored(run: RunHost, args: dict[str, Any]) -> None:
    value = args["value"]
    kind = args.get("type") or _type_of(value)
    await put_value(run.storage, run.program, args["name"], str(kind), value)


def _type_of(value: Any) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "list"
    return "json"
