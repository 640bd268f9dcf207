"""The Python each vision block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def vision_detect(block: Block, g: Generator) -> str:
    return f"detect({py_string(choice(block, g, 'DETECTOR'))})"


def vision_find(block: Block, g: Generator) -> str:
    return f"detection_find({g.value(block, 'DETECTIONS')}, {g.value(block, 'LABEL', '0')})"


def vision_grip_pose(block: Block, g: Generator) -> str:
    return f"detection_grip_pose({g.value(block, 'DETECTION')})"


def vision_above(block: Block, g: Generator) -> str:
    return f"detection_above({g.value(block, 'DETECTION')}, {g.value(block, 'HEIGHT', '100')})"


def vision_count(block: Block, g: Generator) -> str:
    return f"detection_count({g.value(block, 'DETECTIONS')})"
