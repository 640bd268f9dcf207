"""The Python each I/O block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def io_set_output(block: Block, g: Generator) -> list[str]:
    name = py_string(choice(block, g, "NAME"))
    return [f"set_output({name}, bool({g.value(block, 'VALUE', 'False')}))"]


def io_get_input(block: Block, g: Generator) -> str:
    return f"get_input({py_string(choice(block, g, 'NAME'))})"


def io_get_output(block: Block, g: Generator) -> str:
    return f"get_output({py_string(choice(block, g, 'NAME'))})"


def io_wait_input(block: Block, g: Generator) -> list[str]:
    name = py_string(choice(block, g, "NAME"))
    state = choice(block, g, "STATE") == "TRUE"
    return [f"wait_for_input({name}, {state}, {g.value(block, 'TIMEOUT', '10')})"]


def io_set_analog(block: Block, g: Generator) -> list[str]:
    name = py_string(choice(block, g, "NAME"))
    return [f"set_analog_output({name}, {g.value(block, 'VALUE', '0')})"]


def io_get_analog(block: Block, g: Generator) -> str:
    return f"get_analog({py_string(choice(block, g, 'NAME'))})"
