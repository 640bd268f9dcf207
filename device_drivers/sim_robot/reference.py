"""A joint trajectory as a reference signal: position and velocity at any time."""

from __future__ import annotations

import numpy as np

from runtime.interfaces.limits import CheckedTrajectory, FloatArray


class TrajectoryReference:
    """Linear between waypoints, or cubic Hermite when waypoint velocities are given."""

    def __init__(self, trajectory: CheckedTrajectory) -> None:
        self.times = trajectory.times
        self.positions = trajectory.positions
        self.velocities = trajectory.velocities
        self.duration = trajectory.duration
        self.end = trajectory.positions[-1]

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
        if self.velocities is None:
            return p0 + s * (p1 - p0), (p1 - p0) / h, np.zeros_like(p0)
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h
        s2, s3 = s * s, s * s * s
        position = (
            (2 * s3 - 3 * s2 + 1) * p0
            + (s3 - 2 * s2 + s) * v0
            + (-2 * s3 + 3 * s2) * p1
            + (s3 - s2) * v1
        )
        velocity = (
            (6 * s2 - 6 * s) * p0
            + (3 * s2 - 4 * s + 1) * v0
            + (-6 * s2 + 6 * s) * p1
            + (3 * s2 - 2 * s) * v1
        ) / h
        acceleration = (
            (12 * s - 6) * p0 + (6 * s - 4) * v0 + (6 - 12 * s) * p1 + (6 * s - 2) * v1
        ) / (h * h)
        return position, velocity, acceleration
