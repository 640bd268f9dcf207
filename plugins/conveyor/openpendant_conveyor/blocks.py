"""The Python the conveyor's blocks become (each calls this plugin's sandbox functions)."""

from __future__ import annotations

import re

from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block, WorkspaceError

LOCAL_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")


def _conveyor(block: Block, g: Generator) -> str:
    name = g.text_field(block, "CONVEYOR")
    if not LOCAL_NAME.match(name):
        raise WorkspaceError(f"block {block.type}: choose a conveyor", block.id)
    return py_string(name)


def conveyor_run(block: Block, g: Generator) -> list[str]:
    return [f"run_conveyor({_conveyor(block, g)}, {g.value(block, 'SPEED', '0')})"]


def conveyor_wait_part(block: Block, g: Generator) -> list[str]:
    return [f"wait_for_part({_conveyor(block, g)}, {g.value(block, 'TIMEOUT', '10')})"]
