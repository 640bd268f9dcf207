"""Planned joint moves (jog steps, hold-to-run "move to", the motion service's move joint):
time-optimal, jerk-limited and synchronized across joints (ruckig), slowed as a whole until
the TCP stays under the speed cap."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory

from runtime.interfaces.limits import FloatArray
from runtime.interfaces.robot import RobotInfo
from runtime.robotics.kinematics import Kinematics

# Planned moves run at most at this fraction of the joints' limits (at 100 % override).
MOVE_SPEED_FRACTION = 0.5
SAMPLES_FOR_TCP_CHECK = 200


@dataclass
class PlannedMove:
    trajectory: Trajectory
    goal: FloatArray

    @property
    def duration(self) -> float:
        return float(self.trajectory.duration)

    def sample(self, t: float) -> tuple[FloatArray, FloatArray]:
        position, velocity, _ = self.state(t)
        return position, velocity

    def state(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, velocity and acceleration at time t."""
        position, velocity, acceleration = self.trajectory.at_time(min(max(t, 0.0), self.duration))
        return np.array(position), np.array(velocity), np.array(acceleration)


def peak_tcp_speed(kinematics: Kinematics, trajectory: Trajectory) -> float:
    peak = 0.0
    for t in np.linspace(0.0, float(trajectory.duration), SAMPLES_FOR_TCP_CHECK):
        position, velocity, _ = trajectory.at_time(float(t))
        jacobian = kinematics.jacobian(np.array(position))
        peak = max(peak, float(np.linalg.norm(jacobian[:3] @ np.array(velocity))))
    return peak


def plan_joint_move(
    kinematics: Kinematics,
    info: RobotInfo,
    start: FloatArray,
    goal: FloatArray,
    speed: float,
    tcp_cap: float | None,
    start_velocity: FloatArray | None = None,
    *,
    acceleration: float | None = None,
    fraction: float = MOVE_SPEED_FRACTION,
) -> PlannedMove:
    """`speed` (and `acceleration`, which defaults to it) scale the joints' limits, times
    `fraction`: jogging moves never use the last half of a joint's speed."""
    n = info.dof
    scale = fraction * speed
    accel_scale = fraction * (speed if acceleration is None else acceleration)
    for _ in range(8):
        otg = Ruckig(n)
        inp = InputParameter(n)
        inp.current_position = start.tolist()
        inp.current_velocity = (np.zeros(n) if start_velocity is None else start_velocity).tolist()
        inp.current_acceleration = [0.0] * n
        inp.target_position = goal.tolist()
        # Phase synchronization keeps a move from rest on the straight joint-space line, the
        # path that collision checking saw.
        inp.synchronization = Synchronization.Phase
        inp.target_velocity = [0.0] * n
        inp.target_acceleration = [0.0] * n
        inp.max_velocity = [j.max_velocity * scale for j in info.joints]
        inp.max_acceleration = [j.max_acceleration * accel_scale for j in info.joints]
        inp.max_jerk = [(j.max_jerk or math.inf) * accel_scale for j in info.joints]
        trajectory = Trajectory(n)
        result = otg.calculate(inp, trajectory)
        if result not in (Result.Working, Result.Finished):
            raise RuntimeError(f"cannot plan the move: {result}")
        if tcp_cap is None:
            break
        peak = peak_tcp_speed(kinematics, trajectory)
        if peak <= tcp_cap:
            break
        # Slower in time, same path: velocity, acceleration and jerk limits scale together.
        scale *= 0.95 * tcp_cap / peak
        accel_scale *= 0.95 * tcp_cap / peak
    return PlannedMove(trajectory, goal.copy())
