"""Building Blockly workspaces (the JSON Blockly saves) in tests."""

from __future__ import annotations

import itertools
from typing import Any

_ids = itertools.count(1)

Block = dict[str, Any]


def block(kind: str, fields: dict[str, Any] | None = None, **inputs: Block | None) -> Block:
    made: Block = {"type": kind, "id": f"{kind}-{next(_ids)}"}
    if fields:
        made["fields"] = fields
    if inputs:
        made["inputs"] = {name: {"block": b} for name, b in inputs.items() if b is not None}
    return made


def stack(*blocks: Block) -> Block:
    for a, b in itertools.pairwise(blocks):
        a["next"] = {"block": b}
    return blocks[0]


def number(n: float) -> Block:
    return block("math_number", {"NUM": n})


def text(t: str) -> Block:
    return block("text", {"TEXT": t})


def var(name: str) -> Block:
    return block("variables_get", {"VAR": {"id": name}})


def waypoint(name: str) -> Block:
    return block("waypoint_get", {"WAYPOINT": name})


def workspace(*tops: Block, variables: tuple[str, ...] = ()) -> dict[str, Any]:
    return {
        "blocks": {"languageVersion": 0, "blocks": list(tops)},
        "variables": [{"name": v, "id": v} for v in variables],
    }


def ids_of(top: Block) -> list[str]:
    """Every block id in a stack, nested ones included."""
    found = []
    pending = [top]
    while pending:
        b = pending.pop()
        found.append(b["id"])
        for connection in b.get("inputs", {}).values():
            pending.append(connection["block"])
        if "next" in b:
            pending.append(b["next"]["block"])
    return found
