"""The blocks as the editor and the generator see them: every plugin's blocks (the project's
own are the built-in "blocks" plugin's, one folder per category) placed into the
toolbox (toolbox.json holds its categories and Blockly's standard blocks; a category with a
`toolboxitemid` takes the blocks declared for it). Dropdowns marked with "op_options" are
filled by the UI from the runtime (robots, waypoints, I/O names); their values are checked
by the runtime when the program runs, not against the placeholder options here."""

from __future__ import annotations

import copy
import json
from functools import cache
from pathlib import Path
from typing import Any

from openpendant.plugins.api import Block
from openpendant.plugins.registry import registry

HERE = Path(__file__).parent
TOOLBOX = HERE / "toolbox.json"


def blocks() -> dict[str, Block]:
    return registry().blocks


@cache
def definitions() -> dict[str, list[dict[str, Any]]]:
    """Category id -> the Blockly definitions of its blocks."""
    found: dict[str, list[dict[str, Any]]] = {}
    for block in blocks().values():
        found.setdefault(block.category, []).append({"type": block.type, **block.definition})
    return found


def definition(block_type: str) -> dict[str, Any] | None:
    block = blocks().get(block_type)
    return None if block is None else {"type": block.type, **block.definition}


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
    entries: dict[str, list[dict[str, Any]]] = {}
    for block in blocks().values():
        entry = dict(block.toolbox) if block.toolbox else {"kind": "block", "type": block.type}
        entries.setdefault(block.category, []).append(entry)
    contents: list[dict[str, Any]] = data["contents"]
    placed = set()
    for item in contents:
        category = item.get("toolboxitemid")
        if item.get("kind") == "category" and category in entries:
            item["contents"] = entries[category]
            placed.add(category)
    # The plugins' own categories go after the project's, before Variables and Functions.
    at = max(i for i, item in enumerate(contents) if item.get("kind") == "sep")
    for category in registry().categories.values():
        if category.id in placed:
            continue
        contents.insert(
            at,
            {
                "kind": "category",
                "name": category.name.get("en", category.id),
                "colour": category.colour,
                "toolboxitemid": category.id,
                "contents": entries.get(category.id, []),
            },
        )
        at += 1
        placed.add(category.id)
    registry_ = registry()
    for category in set(entries) - placed:
        for entry in entries[category]:
            owner = registry_.owner.get(("block", entry["type"]), "?")
            registry_.fail(owner, entry["type"], f"no toolbox category {category!r}")
    return data


@cache
def words() -> dict[str, dict[str, Any]]:
    """The blocks' translations (the core's categories' words.json, the plugins' Block
    declarations): per language, block words by type, and the plugins' category names by
    their English name (the UI's own catalogue has the core toolbox's)."""
    found: dict[str, dict[str, Any]] = {}
    for block in blocks().values():
        for language, texts in block.words.items():
            found.setdefault(language, {"blocks": {}, "categories": {}})["blocks"][block.type] = (
                copy.deepcopy(dict(texts))
            )
    for category in registry().categories.values():
        english = category.name.get("en", category.id)
        for language, name in category.name.items():
            if language != "en":
                found.setdefault(language, {"blocks": {}, "categories": {}})["categories"][
                    english
                ] = name
    return found


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
