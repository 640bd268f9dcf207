"""The Python each stored-variable block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def store_get(block: Block, g: Generator) -> str:
    return f"stored({py_string(choice(block, g, 'NAME'))})"


def store_set(block: Block, g: Generator) -> list[str]:
    return [f"store({py_string(choice(block, g, 'NAME'))}, {g.value(block, 'VALUE')})"]
