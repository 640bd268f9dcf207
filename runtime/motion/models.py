"""Requests and answers of the motion service."""

from __future__ import annotations

from enum import StrEnum
from typing import Literal

from pydantic import BaseModel, Field, model_validator

from openpendant.runtime.interfaces.common import JointVector, Pose, Strict
from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.interfaces.variables import VARIABLE_NAME
from openpendant.runtime.kit.words import Words

Ratio = Field(default=0.5, gt=0, le=1)


class Target(Strict):
    """One of: joint positions, a TCP pose (in the robot's base frame or the world), or the
    name of a stored waypoint (joint or pose)."""

    joints: JointVector | None = None
    pose: Pose | None = None
    frame: Literal["base", "world"] = "base"
    waypoint: str | None = Field(default=None, pattern=VARIABLE_NAME)
    # Corner rounding at this point when passing through it (m for TCP paths, rad for joint
    # paths); 0 stops there.
    blend: float = Field(default=0.0, ge=0, le=1.0)

    @model_validator(mode="after")
    def _one(self) -> Target:
        given = [v is not None for v in (self.joints, self.pose, self.waypoint)]
        if sum(given) != 1:
            raise ValueError("give exactly one of joints, pose or waypoint")
        return self


class MoveKind(StrEnum):
    joint = "joint"  # to a target, joint-interpolated (time-optimal, synchronized)
    linear = "linear"  # to a target, the TCP on a straight line
    path = "path"  # through waypoints, TCP lines (linear) or joint-interpolated, blended
    relative = "relative"  # by an offset of the TCP, in the base or tool frame
    # To a target with no plan: steered each cycle, keeping clear of obstacles and of the
    # other robots as they move (real-time avoidance); stops where it is blocked.
    reactive = "reactive"


class MoveRequest(Strict):
    kind: MoveKind
    target: Target | None = None
    waypoints: list[Target] = Field(default_factory=list, max_length=500)
    linear: bool = True  # for `path`: TCP lines between the waypoints, else joint lines
    offset: Pose | None = None  # for `relative`
    offset_frame: Literal["base", "tool"] = "base"
    speed: float = Ratio  # of the joints' velocity limits
    acceleration: float = Ratio  # of their acceleration limits
    # When the direct joint path collides, search a path around the obstacles.
    avoid_obstacles: bool = True
    margin: float = Field(default=0.005, ge=0, le=0.5)  # m kept from every obstacle

    @model_validator(mode="after")
    def _complete(self) -> MoveRequest:
        if self.kind in (MoveKind.joint, MoveKind.linear, MoveKind.reactive) and (
            self.target is None
        ):
            raise ValueError(f"a {self.kind} move needs a target")
        if self.kind is MoveKind.path and not self.waypoints:
            raise ValueError("a path move needs waypoints")
        if self.kind is MoveKind.relative and self.offset is None:
            raise ValueError("a relative move needs an offset")
        return self


class CollisionReport(BaseModel):
    robot_part: str
    other: str
    distance: float
    position: list[float]
    point: list[float]
    message: str


class PlanReport(BaseModel):
    """A checked plan: feasible or not, with the reason, and the TCP path for the 3D view."""

    ok: bool
    code: str = ""
    message: str = ""
    words: Words | None = None  # the message as a UI says it in its language
    duration: float = 0.0
    planned_around: bool = False
    collision: CollisionReport | None = None
    tcp_path: list[list[float]] = Field(default_factory=list)  # world frame, m
    goal: list[float] = Field(default_factory=list)


class MoveState(StrEnum):
    planning = "planning"
    running = "running"
    paused = "paused"  # stopped on its path; resumes where it stopped
    finished = "finished"
    cancelled = "cancelled"
    failed = "failed"


class MoveStatus(BaseModel):
    id: str
    robot: str
    state: MoveState
    code: str = ""  # why it failed, for programs: e.g. "blocked", "cancelled", "estop"
    message: str = ""
    words: Words | None = None  # the message as a UI says it in its language
    progress: float = 0.0
    plan: PlanReport | None = None
    caller: str | None = None  # who asked for it (X-Caller), e.g. a program run
    paused: bool = False  # asked to pause (it stops on its path, or starts paused)


class Clearance(BaseModel):
    """The nearest pair of a robot's moving parts and anything else, now (all None: nothing
    else in its scene)."""

    robot: str
    distance: float | None  # m
    robot_part: str | None = None
    other: str | None = None
    points: list[list[float]] | None = None  # on the robot's part, on the other (world, m)


class SceneRobot(BaseModel):
    base: Pose  # in the world
    joints: list[float]  # rad, as the motion service last read them


class Scene(BaseModel):
    """The world the motion service checks moves in."""

    robots: dict[str, SceneRobot]
    objects: dict[str, SceneObject]
