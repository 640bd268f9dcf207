"""Generators for the project's blocks (definitions/*.json, which name them): robot, waypoints
and poses, time, I/O, the variable storage and program control. Each calls sandbox
functions."""

from __future__ import annotations

from openpendant.blockly_blocks.catalog import static_options
from openpendant.blockly_blocks.generator import Generator, block_kind, py_string
from openpendant.blockly_blocks.workspace import Block, WorkspaceError
from openpendant.runtime.kit.words import words

MAX_NAME = 128


def _choice(block: Block, g: Generator, name: str) -> str:
    options = static_options(block.type, name)
    if options is not None:
        return g.option(block, name, options)
    text = g.text_field(block, name)
    if not text:
        raise WorkspaceError(
            f"block {block.type}: no {name.lower()} chosen",
            block.id,
            words("program.nothing_chosen", block=block_kind(block)),
        )
    if not len(text) <= MAX_NAME or not text.isprintable():
        raise WorkspaceError(f"block {block.type}: {name} must be a short name", block.id)
    return text


# Robot ------------------------------------------------------------------------------------


def robot_use(block: Block, g: Generator) -> list[str]:
    return [f"use_robot({py_string(_choice(block, g, 'ROBOT'))})"]


def robot_move(block: Block, g: Generator) -> list[str]:
    fn = "move_joint" if block.type == "robot_move_joint" else "move_linear"
    return [f"{fn}({g.value(block, 'TARGET')})"]


def robot_move_relative(block: Block, g: Generator) -> list[str]:
    x, y, z = (g.value(block, axis, "0") for axis in ("X", "Y", "Z"))
    frame = _choice(block, g, "FRAME")
    return [f"move_relative({x}, {y}, {z}, {frame!r})"]


def robot_set_speed(block: Block, g: Generator) -> list[str]:
    return [f"set_speed({g.value(block, 'SPEED', '100')})"]


def robot_joint_positions(block: Block, g: Generator) -> str:
    return "joint_positions()"


def robot_tcp_pose(block: Block, g: Generator) -> str:
    return "tcp_pose()"


def robot_tool(block: Block, g: Generator) -> list[str]:
    return ["tool_open()" if _choice(block, g, "ACTION") == "OPEN" else "tool_close()"]


def robot_home(block: Block, g: Generator) -> list[str]:
    return ["move_home()"]


# Waypoints and poses ----------------------------------------------------------------------


def waypoint_get(block: Block, g: Generator) -> str:
    return f"waypoint({py_string(_choice(block, g, 'WAYPOINT'))})"


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
    component = _choice(block, g, "COMPONENT")
    return f"pose_get({g.value(block, 'POSE')}, {component!r})"


def pose_set_component(block: Block, g: Generator) -> str:
    component = _choice(block, g, "COMPONENT")
    return f"pose_set({g.value(block, 'POSE')}, {component!r}, {g.value(block, 'VALUE', '0')})"


# Time -------------------------------------------------------------------------------------


def time_wait(block: Block, g: Generator) -> list[str]:
    return [f"wait({g.value(block, 'SECONDS', '0')})"]


def time_wait_until(block: Block, g: Generator) -> list[str]:
    condition = g.value(block, "CONDITION", "True")
    return [f"wait_until(lambda: {condition}, {g.value(block, 'TIMEOUT', '10')})"]


# I/O --------------------------------------------------------------------------------------


def io_set_output(block: Block, g: Generator) -> list[str]:
    name = py_string(_choice(block, g, "NAME"))
    return [f"set_output({name}, bool({g.value(block, 'VALUE', 'False')}))"]


def io_get_input(block: Block, g: Generator) -> str:
    return f"get_input({py_string(_choice(block, g, 'NAME'))})"


def io_get_output(block: Block, g: Generator) -> str:
    return f"get_output({py_string(_choice(block, g, 'NAME'))})"


def io_wait_input(block: Block, g: Generator) -> list[str]:
    name = py_string(_choice(block, g, "NAME"))
    state = _choice(block, g, "STATE") == "TRUE"
    return [f"wait_for_input({name}, {state}, {g.value(block, 'TIMEOUT', '10')})"]


def io_set_analog(block: Block, g: Generator) -> list[str]:
    name = py_string(_choice(block, g, "NAME"))
    return [f"set_analog_output({name}, {g.value(block, 'VALUE', '0')})"]


def io_get_analog(block: Block, g: Generator) -> str:
    return f"get_analog({py_string(_choice(block, g, 'NAME'))})"


# Grippers ----------------------------------------------------------------------------------


def _gripper(block: Block, g: Generator) -> str:
    return py_string(_choice(block, g, "GRIPPER"))


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


# Variable storage -------------------------------------------------------------------------


def store_get(block: Block, g: Generator) -> str:
    return f"stored({py_string(_choice(block, g, 'NAME'))})"


def store_set(block: Block, g: Generator) -> list[str]:
    return [f"store({py_string(_choice(block, g, 'NAME'))}, {g.value(block, 'VALUE')})"]


# Program ----------------------------------------------------------------------------------


def program_log(block: Block, g: Generator) -> list[str]:
    level = _choice(block, g, "LEVEL")
    return [f"log({g.value(block, 'TEXT', repr(''))}, {level!r})"]


def program_confirm(block: Block, g: Generator) -> list[str]:
    return [f"confirm({g.value(block, 'MESSAGE', repr('Continue?'))})"]


def program_stop(block: Block, g: Generator) -> list[str]:
    return ["stop_program()"]
