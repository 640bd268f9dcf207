"""The Python each robot block generates: calls of the functions in functions.py."""

from __future__ import annotations

from openpendant.blockly_blocks.fields import choice
from openpendant.blockly_blocks.generator import Generator, py_string
from openpendant.blockly_blocks.workspace import Block


def robot_use(block: Block, g: Generator) -> list[str]:
    return [f"use_robot({py_string(choice(block, g, 'ROBOT'))})"]


def robot_move(block: Block, g: Generator) -> list[str]:
    fn = "move_joint" if block.type == "robot_move_joint" else "move_linear"
    return [f"{fn}({g.value(block, 'TARGET')})"]


def robot_move_relative(block: Block, g: Generator) -> list[str]:
    x, y, z = (g.value(block, axis, "0") for axis in ("X", "Y", "Z"))
    frame = choice(block, g, "FRAME")
    return [f"move_relative({x}, {y}, {z}, {frame!r})"]


def robot_set_speed(block: Block, g: Generator) -> list[str]:
    return [f"set_speed({g.value(block, 'SPEED', '100')})"]


def robot_joint_positions(block: Block, g: Generator) -> str:
    return "joint_positions()"


def robot_tcp_pose(block: Block, g: Generator) -> str:
    return "tcp_pose()"


def robot_tool(block: Block, g: Generator) -> list[str]:
    return ["tool_open()" if choice(block, g, "ACTION") == "OPEN" else "tool_close()"]


def robot_home(block: Block, g: Generator) -> list[str]:
    return ["move_home()"]
