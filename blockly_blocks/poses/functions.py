"""Waypoints and poses: look up a taught waypoint, build a pose from x, y, z (mm) and roll,
pitch, yaw (degrees), compose, invert, offset, and read or replace one component."""

from __future__ import annotations

import math
from typing import Any

from openpendant.sandbox.guards import SandboxError
from openpendant.sandbox.library.base import host, sandbox_function, text_arg
from openpendant.sandbox.values import Pose, Waypoint, check_number

COMPONENTS = ("x", "y", "z", "roll", "pitch", "yaw")


def _pose(value: Any, what: str = "pose") -> Pose:
    if not isinstance(value, Pose):
        raise SandboxError(f"{what} must be a pose, not {type(value).__name__}")
    return value


def _component(name: Any) -> str:
    if name not in COMPONENTS:
        raise SandboxError(f"a pose component is one of {', '.join(COMPONENTS)}")
    return str(name)


@sandbox_function
def waypoint(name: str) -> Waypoint:
    """A taught waypoint; fails at once if there is none of that name."""
    found = host().call("waypoint.check", {"name": text_arg(name, "waypoint name")})
    return Waypoint(name, str(found["type"]))


@sandbox_function
def pose(x: Any, y: Any, z: Any, roll: Any = 0, pitch: Any = 0, yaw: Any = 0) -> Pose:
    """A pose from x, y, z in mm and roll, pitch, yaw in degrees."""
    return Pose.from_user(x, y, z, roll, pitch, yaw)


@sandbox_function
def pose_compose(first: Any, second: Any) -> Pose:
    """`second` expressed in the frame of `first` (first · second)."""
    return _pose(first, "the first pose").compose(_pose(second, "the second pose"))


@sandbox_function
def pose_inverse(value: Any) -> Pose:
    return _pose(value).inverse()


@sandbox_function
def pose_offset(value: Any, x: Any = 0, y: Any = 0, z: Any = 0) -> Pose:
    """The pose moved by x, y, z mm along the axes of the frame it is given in."""
    p = _pose(value)
    dx, dy, dz = (check_number(v, n) / 1000.0 for v, n in ((x, "x"), (y, "y"), (z, "z")))
    position = (p.position[0] + dx, p.position[1] + dy, p.position[2] + dz)
    return Pose(position, p.orientation)


@sandbox_function
def pose_get(value: Any, component: str) -> float:
    """x, y, z in mm or roll, pitch, yaw in degrees."""
    return float(getattr(_pose(value), _component(component)))


@sandbox_function
def pose_set(value: Any, component: str, number: Any) -> Pose:
    """A copy of the pose with one component replaced."""
    p = _pose(value)
    parts = {name: float(getattr(p, name)) for name in COMPONENTS}
    parts[_component(component)] = check_number(number, component)
    return Pose.from_user(**parts)


@sandbox_function
def distance(first: Any, second: Any) -> float:
    """Distance between two poses' positions, in mm."""
    a, b = _pose(first, "the first pose"), _pose(second, "the second pose")
    return 1000.0 * math.dist(a.position, b.position)
