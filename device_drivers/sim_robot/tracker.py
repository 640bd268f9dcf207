"""Online trajectory generation with ruckig: every cycle the setpoint moves one step toward
the current target without exceeding the joint velocity, acceleration and jerk limits."""

from __future__ import annotations

import math

import numpy as np
from ruckig import (
    ControlInterface,
    InputParameter,
    OutputParameter,
    Result,
    Ruckig,
    Synchronization,
)

from runtime.interfaces.limits import FloatArray
from runtime.interfaces.robot import JointLimits

_POSITION = ControlInterface.Position
_VELOCITY = ControlInterface.Velocity


class TrackerError(RuntimeError):
    pass


class JointTracker:
    def __init__(self, joints: list[JointLimits], dt: float, position: FloatArray) -> None:
        n = len(joints)
        self.dt = dt
        self.lower = np.array([j.lower for j in joints])
        self.upper = np.array([j.upper for j in joints])
        self.max_velocity = np.array([j.max_velocity for j in joints])
        self.max_acceleration = np.array([j.max_acceleration for j in joints])
        self._otg = Ruckig(n, dt)
        self._in = InputParameter(n)
        self._out = OutputParameter(n)
        self._in.max_acceleration = self.max_acceleration.tolist()
        self._in.max_jerk = [j.max_jerk or math.inf for j in joints]
        self._in.synchronization = Synchronization.No
        self._in.current_position = [float(v) for v in position]
        self._in.current_velocity = [0.0] * n
        self._in.current_acceleration = [0.0] * n
        self.position = np.array(position, dtype=float)
        self.velocity = np.zeros(n)
        self.acceleration = np.zeros(n)

    @property
    def moving(self) -> bool:
        return bool(
            np.any(np.abs(self.velocity) > 1e-9) or np.any(np.abs(self.acceleration) > 1e-9)
        )

    def hold(self) -> None:
        """Come to a stop as fast as the limits allow (halt), then stay there."""
        n = len(self.position)
        self._run([_VELOCITY] * n, self.position, np.zeros(n), self.max_velocity)

    def step_velocity(self, velocity: FloatArray) -> None:
        """Move each joint at its commanded velocity, braking so as to stop exactly at its
        position limit instead of running through it."""
        moving = velocity != 0.0
        interfaces = [_POSITION if m else _VELOCITY for m in moving]
        target = np.where(velocity > 0, self.upper, self.lower)
        target = np.where(moving, target, self.position)
        speed = np.where(moving, np.minimum(np.abs(velocity), self.max_velocity), self.max_velocity)
        self._run(interfaces, target, np.zeros_like(velocity), speed)

    def step_position(
        self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray | None = None
    ) -> None:
        """Track a moving reference (position, its velocity and acceleration)."""
        target = np.clip(position, self.lower, self.upper)
        # A reference still heading for a limit must be able to stop before it.
        room = np.where(velocity > 0, self.upper - target, target - self.lower)
        stop_speed = np.sqrt(2.0 * self.max_acceleration * np.maximum(room, 0.0))
        capped = np.clip(
            velocity,
            -np.minimum(stop_speed, self.max_velocity),
            np.minimum(stop_speed, self.max_velocity),
        )
        accel = np.zeros_like(position) if acceleration is None else acceleration
        # Arriving with the reference's acceleration avoids a lag; keep it inside the limit.
        accel = np.where(
            capped == velocity,
            np.clip(accel, -0.9 * self.max_acceleration, 0.9 * self.max_acceleration),
            0.0,
        )
        self._run([_POSITION] * len(position), target, capped, self.max_velocity, accel)

    def _run(
        self,
        interfaces: list[ControlInterface],
        target_position: FloatArray,
        target_velocity: FloatArray,
        max_velocity: FloatArray,
        target_acceleration: FloatArray | None = None,
    ) -> None:
        self._in.per_dof_control_interface = interfaces
        self._in.target_acceleration = (
            [0.0] * len(interfaces) if target_acceleration is None else target_acceleration.tolist()
        )
        self._in.target_position = target_position.tolist()
        self._in.target_velocity = target_velocity.tolist()
        self._in.max_velocity = max_velocity.tolist()
        result = self._otg.update(self._in, self._out)
        if result not in (Result.Working, Result.Finished):
            raise TrackerError(f"trajectory generation failed: {result}")
        self._out.pass_to_input(self._in)
        self.position = np.array(self._out.new_position)
        self.velocity = np.array(self._out.new_velocity)
        self.acceleration = np.array(self._out.new_acceleration)
