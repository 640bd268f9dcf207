"""A core block category is one folder (blockly_blocks/<category>/): its blocks' definitions,
generators, sandbox functions, runtime handlers and words, registered through the plugin API
as a plugin's blocks are, and nothing of them anywhere else."""

from __future__ import annotations

import importlib
import inspect
import json
import re
from pathlib import Path

import pytest

from openpendant.blockly_blocks.catalog import toolbox
from openpendant.plugins.api import Block
from openpendant.plugins.registry import registry

pytestmark = pytest.mark.concurrent

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = sorted(p.parent for p in (ROOT / "blockly_blocks").glob("*/blocks.json"))


def core_blocks() -> list[Block]:
    owner = registry().owner
    return [b for b in registry().blocks.values() if owner[("block", b.type)] == "blocks"]


def test_every_core_block_comes_from_a_category_folder() -> None:
    assert [f.name for f in FOLDERS] == [
        "gripper",
        "io",
        "poses",
        "program",
        "robot",
        "store",
        "time",
        "vision",
    ]
    declared = {
        entry["type"]: folder.name
        for folder in FOLDERS
        for entry in json.loads((folder / "blocks.json").read_text())
    }
    assert {b.type: b.category for b in core_blocks()} == declared
    in_toolbox = {c.get("toolboxitemid") for c in toolbox()["contents"]}
    assert {f.name for f in FOLDERS} <= in_toolbox


def test_what_a_block_names_lives_in_its_own_folder() -> None:
    for block in core_blocks():
        folder = ROOT / "blockly_blocks" / block.category
        references = [block.generator, *block.functions.values(), *block.handlers.values()]
        for reference in references:
            module, _, attribute = reference.partition(":")
            loaded = importlib.import_module(module)
            assert callable(getattr(loaded, attribute)), reference
            source = Path(inspect.getfile(loaded)).resolve()
            assert source.parent == folder.resolve(), f"{block.type}: {reference}"


def test_every_core_block_has_its_german_words_beside_it() -> None:
    """As a plugin's: message and tooltip, the same %1, %2… as the English in any order,
    and dropdown labels only for values the dropdown has."""
    for block in core_blocks():
        words = block.words.get("de")
        assert words is not None, f"{block.type} has no German words"
        assert {"message0", "tooltip"} <= set(words), block.type
        english = set(re.findall(r"%\d", block.definition["message0"]))
        assert set(re.findall(r"%\d", words["message0"])) == english, block.type
        fields = {
            arg["name"]: {option[1] for option in arg.get("options", [])}
            for key, args in block.definition.items()
            if key.startswith("args")
            for arg in args
            if arg.get("type") == "field_dropdown"
        }
        for field, labels in words.get("options", {}).items():
            assert set(labels) <= fields[field], (block.type, field)
