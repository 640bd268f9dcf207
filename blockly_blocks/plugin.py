"""The project's own blocks, registered through the plugin API like a plugin's: each entry of
definitions/<category>.json is one block, declared once — its Blockly definition, its
toolbox entry ("toolbox"), its Python generator ("generator"), the sandbox functions that
Python calls ("functions") and the runtime's answers to them ("handlers")."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from openpendant.plugins.api import Block, Plugin

DEFINITIONS = Path(__file__).parent / "definitions"
DECLARATION = ("type", "toolbox", "generator", "functions", "handlers")


def _block(category: str, entry: dict[str, Any]) -> Block:
    return Block(
        type=entry["type"],
        category=category,
        definition={k: v for k, v in entry.items() if k not in DECLARATION},
        generator=entry["generator"],
        toolbox=entry.get("toolbox"),
        functions=entry.get("functions", {}),
        handlers=entry.get("handlers", {}),
    )


def blocks() -> tuple[Block, ...]:
    return tuple(
        _block(path.stem, entry)
        for path in sorted(DEFINITIONS.glob("*.json"))
        for entry in json.loads(path.read_text())
    )


PLUGIN = Plugin(
    name="blocks",
    description="The robot, waypoint and pose, time, I/O, stored-variable and program blocks",
    blocks=blocks(),
)
