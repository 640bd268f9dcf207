"""Robot functions: moves through the motion service (limits, collisions, manual-mode speed
cap and the control lease are the runtime's business), state, tool and home. Distances in
mm, angles in degrees, speed in percent of the robot's limits."""

from __future__ import annotations

import math
from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import host, number_arg, sandbox_function, text_arg
from openpendant.sandbox.values import Pose, Waypoint, check_number

MAX_JOINTS = 64


def target_wire(target: Any) -> dict[str, Any]:
    """A move target as the motion service takes it."""
    if isinstance(target, Waypoint):
        return {"waypoint": target.name}
    if isinstance(target, Pose):
        return {"pose": target.wire(), "frame": "base"}
    if isinstance(target, list | tuple):
        if not 0 < len(target) <= MAX_JOINTS:
            raise SandboxError("joint positions are a list of one value per joint")
        return {
            "joints": [
                math.radians(check_number(v, f"joint {i + 1}")) for i, v in enumerate(target)
            ]
        }
    raise SandboxError(
        f"a move goes to a waypoint, a pose or joint positions, not a {type(target).__name__}"
    )


@sandbox_function
def use_robot(name: str) -> None:
    """Make `name` the robot the following robot blocks command."""
    host().call("robot.use", {"robot": text_arg(name, "robot name", max_length=32)})


@sandbox_function
def move_joint(target: Any) -> None:
    """Move to a waypoint, pose or joint positions (degrees), joint-interpolated."""
    host().call("robot.move", {"kind": "joint", "target": target_wire(target)})


@sandbox_function
def move_linear(target: Any) -> None:
    """Move the TCP on a straight line to a waypoint, pose or joint positions."""
    host().call("robot.move", {"kind": "linear", "target": target_wire(target)})


@sandbox_function
def move_relative(x: Any = 0, y: Any = 0, z: Any = 0, frame: str = "base") -> None:
    """Move the TCP by x, y, z mm along the base or tool axes, on a straight line."""
    if frame not in ("base", "tool"):
        raise SandboxError('the frame of a relative move is "base" or "tool"')
    offset = Pose.from_user(x, y, z)
    host().call("robot.move_relative", {"offset": offset.wire(), "frame": frame})


@sandbox_function
def set_speed(percent: Any) -> None:
    """Speed of the following moves, in percent of the robot's limits (1-100)."""
    host().call("robot.speed", {"ratio": number_arg(percent, "speed", low=1, high=100) / 100})


@sandbox_function
def joint_positions() -> list[float]:
    """The active robot's joint positions, in degrees."""
    joints = host().call("robot.joints", {})
    return [math.degrees(float(v)) for v in joints]


@sandbox_function
def tcp_pose() -> Pose:
    """The active robot's TCP pose in its base frame."""
    return Pose.from_wire(host().call("robot.tcp", {}))


@sandbox_function
def tool_open() -> None:
    """Open the active robot's tool (gripper)."""
    host().call("robot.tool", {"open": True})


@sandbox_function
def tool_close() -> None:
    """Close the active robot's tool (gripper)."""
    host().call("robot.tool", {"open": False})


@sandbox_function
def move_home() -> None:
    """Joint move to the robot's home position."""
    host().call("robot.home", {})
