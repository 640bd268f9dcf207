"""What one press of a jog button does, cycle by cycle: each tick turns the robot's latest
state into the next streamed command."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from runtime.interfaces.limits import FloatArray
from runtime.interfaces.robot import CommandMode, RobotState
from runtime.jog.planning import PlannedMove
from runtime.jog.velocity import VelocityController
from runtime.kinematics import Kinematics

# The driver halts on its own if the stream stops for this long (the deadman's backstop).
COMMAND_TIMEOUT = 0.2
ARRIVED = 1e-7  # rad: a planned move is done when every joint is this close to its goal


class Action(ABC):
    mode: CommandMode

    def __init__(self, press: str) -> None:
        self.press = press
        self.done = False
        self.ticks = 0

    def tag(self) -> str:
        self.ticks += 1
        return f"{self.press}#{self.ticks}"

    @abstractmethod
    def tick(self, state: RobotState, now: float) -> dict[str, Any]: ...


class JointVelocityJog(Action):
    mode = CommandMode.velocity_command

    def __init__(
        self,
        press: str,
        controller: VelocityController,
        velocity: FloatArray,
        tcp_cap: float | None,
    ) -> None:
        super().__init__(press)
        self.controller = controller
        self.velocity = velocity
        self.tcp_cap = tcp_cap

    def tick(self, state: RobotState, now: float) -> dict[str, Any]:
        q = np.array(state.joint_position_command)
        step = self.controller.from_joint_velocity(q, self.velocity, self.tcp_cap)
        return {
            "type": "velocity_command",
            "velocity": step.velocity.tolist(),
            "timeout": COMMAND_TIMEOUT,
            "tag": self.tag(),
        }


class TwistJog(Action):
    """Cartesian jog: a constant twist in the base frame, or in the tool frame (turned into
    the base frame each cycle, as the tool turns)."""

    mode = CommandMode.velocity_command

    def __init__(
        self,
        press: str,
        controller: VelocityController,
        kinematics: Kinematics,
        twist: FloatArray,
        frame: str,
        tcp_cap: float | None,
    ) -> None:
        super().__init__(press)
        self.controller = controller
        self.kinematics = kinematics
        self.twist = twist
        self.frame = frame
        self.tcp_cap = tcp_cap

    def base_twist(self, q: FloatArray) -> FloatArray:
        if self.frame == "base":
            return self.twist
        rotation = self.kinematics.tcp(q).rotation
        return np.concatenate((rotation @ self.twist[:3], rotation @ self.twist[3:]))

    def tick(self, state: RobotState, now: float) -> dict[str, Any]:
        q = np.array(state.joint_position_command)
        step = self.controller.from_twist(q, self.base_twist(q), self.tcp_cap)
        return {
            "type": "velocity_command",
            "velocity": step.velocity.tolist(),
            "timeout": COMMAND_TIMEOUT,
            "tag": self.tag(),
        }


class PlannedMoveAction(Action):
    """Follow a planned move by streaming its positions; the stream stopping halts it."""

    mode = CommandMode.position_command

    def __init__(self, press: str, move: PlannedMove) -> None:
        super().__init__(press)
        self.move = move
        self.started: float | None = None

    def tick(self, state: RobotState, now: float) -> dict[str, Any]:
        if self.started is None:
            self.started = now
        t = now - self.started
        position, velocity = self.move.sample(t)
        if t >= self.move.duration:
            position, velocity = self.move.goal, np.zeros_like(self.move.goal)
            reached = np.abs(np.array(state.joint_position_command) - self.move.goal)
            still = np.all(np.abs(state.joint_velocity) < 1e-9)
            self.done = bool(np.all(reached < ARRIVED) and still)
        return {
            "type": "position_command",
            "position": position.tolist(),
            "velocity": velocity.tolist(),
            "timeout": COMMAND_TIMEOUT,
            "tag": self.tag(),
        }
