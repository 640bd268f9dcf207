"""The Python each time block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.generator import Generator
from openpendant.blockly_blocks.workspace import Block


def time_wait(block: Block, g: Generator) -> list[str]:
    return [f"wait({g.value(block, 'SECONDS', '0')})"]


def time_wait_until(block: Block, g: Generator) -> list[str]:
    condition = g.value(block, "CONDITION", "True")
    return [f"wait_until(lambda: {condition}, {g.value(block, 'TIMEOUT', '10')})"]


def time_since_start(block: Block, g: Generator) -> str:
    return "seconds_since_start()"
