"""The jog socket's messages. A press starts a jog or a move; the client repeats a heartbeat
for that press at 20 Hz or more while the button is held; release ends it."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, Field, model_validator

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.robot import RobotInfo, RobotState
from openpendant.runtime.interfaces.variables import VARIABLE_NAME

PressId = Annotated[str, Field(min_length=1, max_length=32, pattern=r"^[A-Za-z0-9_.:-]+$")]
RobotName = Annotated[str, Field(min_length=1, max_length=32)]
Speed = Annotated[float, Field(gt=0, le=1)]  # fraction of the jog speed (override)
Token = Annotated[str | None, Field(default=None, max_length=64)]

CARTESIAN_AXES = ("x", "y", "z", "rx", "ry", "rz")
MAX_LINEAR_STEP = 0.01  # m
MAX_ANGULAR_STEP = math.radians(5)


class JogPress(Strict):
    type: Literal["jog"]
    press: PressId
    robot: RobotName
    token: Token = None
    kind: Literal["joint", "cartesian"]
    axis: int | Literal["x", "y", "z", "rx", "ry", "rz"]
    direction: Literal[-1, 1]
    frame: Literal["base", "tool"] = "base"
    speed: Speed = 0.25
    step: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _consistent(self) -> JogPress:
        if self.kind == "joint" and not isinstance(self.axis, int):
            raise ValueError("a joint jog names its joint by number, from 0")
        if self.kind == "cartesian" and not isinstance(self.axis, str):
            raise ValueError("a Cartesian jog names its axis: x, y, z, rx, ry or rz")
        if self.step is not None:
            linear = self.kind == "cartesian" and self.axis in ("x", "y", "z")
            limit = MAX_LINEAR_STEP if linear else MAX_ANGULAR_STEP
            if self.step > limit:
                raise ValueError(
                    f"an incremental step is at most {limit:g} {'m' if linear else 'rad'}"
                )
        return self


class MoveToPress(Strict):
    type: Literal["move_to"]
    press: PressId
    robot: RobotName
    token: Token = None
    waypoint: str = Field(pattern=VARIABLE_NAME)
    speed: Speed = 0.25


class FreedrivePress(Strict):
    """Hold the arm free to be moved by hand while the button is held (robots with the
    `freedrive` capability)."""

    type: Literal["freedrive"]
    press: PressId
    robot: RobotName
    token: Token = None


class Heartbeat(Strict):
    type: Literal["heartbeat"]
    press: PressId


class Release(Strict):
    type: Literal["release"]
    press: PressId


class HaltRequest(Strict):
    """Stop every robot this client has moved, and `robot` too; needs no lease."""

    type: Literal["halt"]
    robot: RobotName | None = None


class MouseBinding(Strict):
    """Drive `robot` from the 3D mouse `device` (enabled), or stop doing so."""

    type: Literal["mouse"]
    robot: RobotName
    token: Token = None
    device: str = Field(min_length=1, max_length=32)
    enabled: bool
    mode: Literal["cartesian", "joint"] = "cartesian"
    frame: Literal["base", "tool"] = "base"
    speed: Speed = 0.25
    joints: list[int] = Field(
        default_factory=lambda: [0, 1, 2, 3, 4, 5], min_length=1, max_length=6
    )
    buttons: dict[str, Literal["teach", "toggle_frame"]] = Field(default_factory=dict)


class TeachRequest(Strict):
    name: str = Field(pattern=VARIABLE_NAME)
    kind: Literal["joint", "pose"] = "joint"
    frame: Literal["base", "world"] = "base"
    tags: list[str] = Field(default_factory=list, max_length=32)
    doc: str = Field(default="", max_length=2000)
    overwrite: bool = False


class SpeedRequest(Strict):
    """The speed override, 0 to 1: it scales the robot's trajectories as they run."""

    ratio: float = Field(gt=0, le=1)


# What the routes answer.


class JogSettings(BaseModel):
    # Where the UI opens its hold-to-run socket: the jog service's own port on the UI's
    # host, at /jog/ws (none: through the webui, /api/jog/ws).
    socket_port: int | None
    deadman_ms: int
    joint_speed: float  # rad/s at 100 %
    linear_speed: float  # m/s
    angular_speed: float  # rad/s
    manual_tcp_speed: float  # m/s, the cap in manual modes
    heartbeat_ms: int
    # A robot's speed override when it first comes into focus on a pendant (and when its
    # link comes up): lowered to this, never raised.
    first_speed_ratio: float


class RobotModel(BaseModel):
    """What the jog panel and the 3D view need: joints, limits, URDF and its packages."""

    name: str  # the robot it describes
    info: RobotInfo
    urdf: str | None  # where the browser loads it from (None: no URDF it can load)
    packages: dict[str, str]  # URDF package -> where its files are served


class Waypoint(BaseModel):
    name: str
    type: Literal["joint_waypoint", "pose_waypoint"]
    tags: list[str]
    doc: str
    updated: float
    tcp_position: list[float]  # m: x, y, z in the robot's base frame


class Halted(BaseModel):
    robot: str
    halted: bool
    state: RobotState | None


class SpeedSet(BaseModel):
    robot: str
    speed_ratio: float


class Avoidance(BaseModel):
    """What Cartesian jogging keeps clear of: the robots and scene objects it knows."""

    ready: bool
    robots: list[str]
    objects: list[str]
