"""The Python each gripper block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def _gripper(block: Block, g: Generator) -> str:
    return py_string(choice(block, g, "GRIPPER"))


def gripper_activate(block: Block, g: Generator) -> list[str]:
    return [f"gripper_activate({_gripper(block, g)})"]


def gripper_open(block: Block, g: Generator) -> list[str]:
    return [f"gripper_open({_gripper(block, g)})"]


def gripper_close(block: Block, g: Generator) -> list[str]:
    return [f"gripper_close({_gripper(block, g)})"]


def gripper_set_force(block: Block, g: Generator) -> list[str]:
    return [f"gripper_set_force({_gripper(block, g)}, {g.value(block, 'FORCE', '50')})"]


def gripper_wait_grip(block: Block, g: Generator) -> list[str]:
    return [f"gripper_wait_for_grip({_gripper(block, g)}, {g.value(block, 'TIMEOUT', '5')})"]


def gripper_holds_part(block: Block, g: Generator) -> str:
    return f"gripper_holds_part({_gripper(block, g)})"
