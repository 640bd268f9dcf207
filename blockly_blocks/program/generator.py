"""The Python each program block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator
from openpendant.blockly_blocks.workspace import Block


def program_log(block: Block, g: Generator) -> list[str]:
    level = choice(block, g, "LEVEL")
    return [f"log({g.value(block, 'TEXT', repr(''))}, {level!r})"]


def program_confirm(block: Block, g: Generator) -> list[str]:
    return [f"confirm({g.value(block, 'MESSAGE', repr('Continue?'))})"]


def program_stop(block: Block, g: Generator) -> list[str]:
    return ["stop_program()"]
