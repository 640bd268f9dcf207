"""The project's block definitions (definitions/<category>.json, Blockly's JSON format) and
the toolbox (toolbox.json), as the UI loads them. Dropdowns marked with "op_options" are
filled by the UI from the runtime (robots, waypoints, I/O names); their values are checked
by the runtime when the program runs, not against the placeholder options here."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

HERE = Path(__file__).parent
DEFINITIONS = HERE / "definitions"
TOOLBOX = HERE / "toolbox.json"


@cache
def definitions() -> dict[str, list[dict[str, Any]]]:
    """Category file name -> its block definitions."""
    return {path.stem: json.loads(path.read_text()) for path in sorted(DEFINITIONS.glob("*.json"))}


@cache
def definition(block_type: str) -> dict[str, Any] | None:
    for blocks in definitions().values():
        for block in blocks:
            if block["type"] == block_type:
                return block
    return None


def static_options(block_type: str, field: str) -> tuple[str, ...] | None:
    """The allowed values of a fixed dropdown; None for text fields and runtime-filled lists."""
    found = definition(block_type)
    if found is None:
        return None
    for key in [k for k in found if k.startswith("args")]:
        for arg in found[key]:
            if arg.get("name") == field and arg.get("type") == "field_dropdown":
                if "op_options" in arg:
                    return None
                return tuple(str(option[1]) for option in arg["options"])
    return None


@cache
def toolbox() -> dict[str, Any]:
    data: dict[str, Any] = json.loads(TOOLBOX.read_text())
    return data


def toolbox_blocks() -> list[dict[str, Any]]:
    """Every block entry of the toolbox, category by category."""
    found: list[dict[str, Any]] = []

    def walk(items: list[dict[str, Any]]) -> None:
        for item in items:
            if item.get("kind") == "block":
                found.append(item)
            walk(item.get("contents", []))

    walk(toolbox()["contents"])
    return found
