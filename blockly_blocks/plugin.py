"""The project's own blocks, registered through the plugin API like a plugin's. A category is
one folder, blockly_blocks/<category>/: each entry of its blocks.json is one block, declared
once (its Blockly definition, its toolbox entry "toolbox", the Python generator
"generator", the sandbox functions that Python calls "functions" and the runtime's answers
to them "handlers", each a "module:function", ".module:function" for a module of the
folder), and words.json holds the blocks' words in other languages. docs/dev/block.md adds
one."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from openpendant.plugins.api import Block, Plugin

HERE = Path(__file__).parent
DECLARATION = ("type", "toolbox", "generator", "functions", "handlers")


def _block(
    category: str, package: str, entry: dict[str, Any], words: dict[str, dict[str, Any]]
) -> Block:
    def absolute(reference: str) -> str:
        return package + reference if reference.startswith(".") else reference

    return Block(
        type=entry["type"],
        category=category,
        definition={k: v for k, v in entry.items() if k not in DECLARATION},
        generator=absolute(entry["generator"]),
        toolbox=entry.get("toolbox"),
        functions={k: absolute(v) for k, v in entry.get("functions", {}).items()},
        handlers={k: absolute(v) for k, v in entry.get("handlers", {}).items()},
        words={
            lang: texts[entry["type"]] for lang, texts in words.items() if entry["type"] in texts
        },
    )


def category_blocks(folder: Path, package: str) -> tuple[Block, ...]:
    """The blocks of one category folder, the Python package `package` (the folder's name is
    the toolbox category's id)."""
    words_file = folder / "words.json"
    words = json.loads(words_file.read_text()) if words_file.is_file() else {}
    entries = json.loads((folder / "blocks.json").read_text())
    return tuple(_block(folder.name, package, entry, words) for entry in entries)


def blocks() -> tuple[Block, ...]:
    return tuple(
        block
        for declared in sorted(HERE.glob("*/blocks.json"))
        for block in category_blocks(declared.parent, f"{__package__}.{declared.parent.name}")
    )


PLUGIN = Plugin(
    name="blocks",
    description="The robot, waypoint and pose, time, I/O, gripper, vision, stored-variable "
    "and program blocks",
    blocks=blocks(),
)
