"""The Python each waypoint and pose block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def waypoint_get(block: Block, g: Generator) -> str:
    return f"waypoint({py_string(choice(block, g, 'WAYPOINT'))})"


def pose_create(block: Block, g: Generator) -> str:
    parts = [g.value(block, n, "0") for n in ("X", "Y", "Z", "ROLL", "PITCH", "YAW")]
    return f"pose({', '.join(parts)})"


def pose_compose(block: Block, g: Generator) -> str:
    return f"pose_compose({g.value(block, 'A')}, {g.value(block, 'B')})"


def pose_inverse(block: Block, g: Generator) -> str:
    return f"pose_inverse({g.value(block, 'POSE')})"


def pose_offset(block: Block, g: Generator) -> str:
    x, y, z = (g.value(block, axis, "0") for axis in ("X", "Y", "Z"))
    return f"pose_offset({g.value(block, 'POSE')}, {x}, {y}, {z})"


def pose_get_component(block: Block, g: Generator) -> str:
    component = choice(block, g, "COMPONENT")
    return f"pose_get({g.value(block, 'POSE')}, {component!r})"


def pose_set_component(block: Block, g: Generator) -> str:
    component = choice(block, g, "COMPONENT")
    return f"pose_set({g.value(block, 'POSE')}, {component!r}, {g.value(block, 'VALUE', '0')})"
