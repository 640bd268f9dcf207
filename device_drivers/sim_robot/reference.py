"""A joint trajectory as a reference signal: position and velocity at any time."""

from __future__ import annotations

import numpy as np

from runtime.interfaces.limits import CheckedTrajectory, FloatArray


class TrajectoryReference:
    """Linear between waypoints, or, when waypoint velocities are given, quintic Hermite with
    each waypoint's acceleration estimated from its neighbours' velocities: continuous in
    acceleration, so a tracker can follow it exactly. (Cubic Hermite pieces jump in
    acceleration at every waypoint; at full speed the jerk-limited tracker could not follow
    the jumps and cut across, 14 mrad off a straight joint move.)"""

    def __init__(self, trajectory: CheckedTrajectory) -> None:
        self.times = trajectory.times
        self.positions = trajectory.positions
        self.velocities = trajectory.velocities
        self.duration = trajectory.duration
        self.end = trajectory.positions[-1]
        self.accelerations = (
            None if self.velocities is None else knot_accelerations(self.times, self.velocities)
        )

    def sample(self, t: float) -> tuple[FloatArray, FloatArray]:
        position, velocity, _ = self.sample_with_acceleration(t)
        return position, velocity

    def sample_with_acceleration(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, velocity and acceleration of the reference at time t."""
        if t >= self.duration:
            return self.end.copy(), np.zeros_like(self.end), np.zeros_like(self.end)
        t = max(t, 0.0)
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        k = min(max(k, 0), len(self.times) - 2)
        t0, t1 = self.times[k], self.times[k + 1]
        h = t1 - t0
        s = (t - t0) / h
        p0, p1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None or self.accelerations is None:
            return p0 + s * (p1 - p0), (p1 - p0) / h, np.zeros_like(p0)
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h
        a0, a1 = self.accelerations[k] * h * h, self.accelerations[k + 1] * h * h
        s2, s3, s4, s5 = s * s, s**3, s**4, s**5
        position = (
            (1 - 10 * s3 + 15 * s4 - 6 * s5) * p0
            + (s - 6 * s3 + 8 * s4 - 3 * s5) * v0
            + (0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5) * a0
            + (0.5 * s3 - s4 + 0.5 * s5) * a1
            + (-4 * s3 + 7 * s4 - 3 * s5) * v1
            + (10 * s3 - 15 * s4 + 6 * s5) * p1
        )
        velocity = (
            (-30 * s2 + 60 * s3 - 30 * s4) * p0
            + (1 - 18 * s2 + 32 * s3 - 15 * s4) * v0
            + (s - 4.5 * s2 + 6 * s3 - 2.5 * s4) * a0
            + (1.5 * s2 - 4 * s3 + 2.5 * s4) * a1
            + (-12 * s2 + 28 * s3 - 15 * s4) * v1
            + (30 * s2 - 60 * s3 + 30 * s4) * p1
        ) / h
        acceleration = (
            (-60 * s + 180 * s2 - 120 * s3) * p0
            + (-36 * s + 96 * s2 - 60 * s3) * v0
            + (1 - 9 * s + 18 * s2 - 10 * s3) * a0
            + (3 * s - 12 * s2 + 10 * s3) * a1
            + (-24 * s + 84 * s2 - 60 * s3) * v1
            + (60 * s - 180 * s2 + 120 * s3) * p1
        ) / (h * h)
        return position, velocity, acceleration


def knot_accelerations(times: FloatArray, velocities: FloatArray) -> FloatArray:
    """Each waypoint's acceleration, from the velocities either side (one side at the ends)."""
    accelerations = np.zeros_like(velocities)
    if len(times) < 2:
        return accelerations
    accelerations[1:-1] = (velocities[2:] - velocities[:-2]) / (times[2:] - times[:-2])[:, None]
    accelerations[0] = (velocities[1] - velocities[0]) / (times[1] - times[0])
    accelerations[-1] = (velocities[-1] - velocities[-2]) / (times[-1] - times[-2])
    return accelerations
