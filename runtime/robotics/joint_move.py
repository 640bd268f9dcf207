"""Planned joint moves (jog steps, hold-to-run "move to", the motion service's move joint):
time-optimal and jerk-limited along the straight joint line (ruckig), slowed as a whole until
the TCP stays under the speed cap."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Trajectory

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.robotics.kinematics import Kinematics

# Planned moves run at most at this fraction of the joints' limits (at 100 % override).
MOVE_SPEED_FRACTION = 0.5
SAMPLES_FOR_TCP_CHECK = 200


@dataclass
class PlannedMove:
    """A move along the straight joint line from `start` to `goal`: `trajectory` is the
    distance travelled along it (one coordinate), every joint at start + direction · s."""

    trajectory: Trajectory
    start: FloatArray
    goal: FloatArray
    direction: FloatArray

    @property
    def duration(self) -> float:
        return float(self.trajectory.duration)

    def sample(self, t: float) -> tuple[FloatArray, FloatArray]:
        position, velocity, _ = self.state(t)
        return position, velocity

    def state(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, velocity and acceleration at time t."""
        s, v, a = self.trajectory.at_time(min(max(t, 0.0), self.duration))
        d = self.direction
        return self.start + d * s[0], d * v[0], d * a[0]


def peak_tcp_speed(kinematics: Kinematics, move: PlannedMove) -> float:
    peak = 0.0
    for t in np.linspace(0.0, move.duration, SAMPLES_FOR_TCP_CHECK):
        position, velocity, _ = move.state(float(t))
        jacobian = kinematics.jacobian(position)
        peak = max(peak, float(np.linalg.norm(jacobian[:3] @ velocity)))
    return peak


def plan_joint_move(
    kinematics: Kinematics,
    info: RobotInfo,
    start: FloatArray,
    goal: FloatArray,
    speed: float,
    tcp_cap: float | None,
    *,
    acceleration: float | None = None,
    fraction: float = MOVE_SPEED_FRACTION,
) -> PlannedMove:
    """`speed` (and `acceleration`, which defaults to it) scale the joints' limits, times
    `fraction`: jogging moves never use the last half of a joint's speed.

    Planned as one coordinate, the distance along the straight joint line (each joint's
    limit divided by its share of the line bounds it), so every joint is on that line at
    every instant: the path collision checking saw. ruckig's phase synchronization of the
    joints meant the same, but falls back to time synchronization where the joints' limits
    are not in proportion: a Panda move left its line by 0.55 rad that way."""
    offset = goal - start
    length = float(np.linalg.norm(offset))
    direction = offset / length if length > 0 else np.zeros_like(offset)
    share = np.abs(direction)
    moving = share > 1e-12

    def along(limits: list[float]) -> float:
        if not np.any(moving):
            return 1.0  # nothing moves: any finite limit
        return float(np.min(np.array(limits)[moving] / share[moving]))

    scale = fraction * speed
    accel_scale = fraction * (speed if acceleration is None else acceleration)
    for _ in range(8):
        otg = Ruckig(1)
        inp = InputParameter(1)
        inp.current_position = [0.0]
        inp.current_velocity = [0.0]
        inp.current_acceleration = [0.0]
        inp.target_position = [length]
        inp.target_velocity = [0.0]
        inp.target_acceleration = [0.0]
        inp.max_velocity = [along([j.max_velocity * scale for j in info.joints])]
        inp.max_acceleration = [along([j.max_acceleration * accel_scale for j in info.joints])]
        inp.max_jerk = [along([(j.max_jerk or math.inf) * accel_scale for j in info.joints])]
        trajectory = Trajectory(1)
        result = otg.calculate(inp, trajectory)
        if result not in (Result.Working, Result.Finished):
            raise RuntimeError(f"cannot plan the move: {result}")
        move = PlannedMove(trajectory, start.copy(), goal.copy(), direction)
        if tcp_cap is None:
            break
        peak = peak_tcp_speed(kinematics, move)
        if peak <= tcp_cap:
            break
        # Slower in time, same path: velocity, acceleration and jerk limits scale together.
        scale *= 0.95 * tcp_cap / peak
        accel_scale *= 0.95 * tcp_cap / peak
    return move
