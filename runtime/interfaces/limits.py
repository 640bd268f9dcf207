"""Checks every robot command passes before anything moves. They live here once; drivers
never see an unchecked vector."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openpendant.runtime.interfaces.robot import JointTrajectory, RobotInfo
from openpendant.runtime.kit.errors import RobotError
from openpendant.runtime.kit.words import words

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

# A trajectory's first waypoint may sit at t=0 only if it is where the robot already is.
START_TOLERANCE = 1e-3
# Float noise allowance on limit comparisons; a real excess is far larger.
LIMIT_EPSILON = 1e-9


@dataclass(frozen=True)
class CheckedTrajectory:
    """Times from 0 (the current position) and positions (and velocities) at each time."""

    times: FloatArray
    positions: FloatArray
    velocities: FloatArray | None
    accelerations: FloatArray | None = None

    @property
    def duration(self) -> float:
        return float(self.times[-1])


class JointLimitChecker:
    def __init__(self, info: RobotInfo) -> None:
        self.names = info.joint_names
        self.lower = np.array([j.lower for j in info.joints])
        self.upper = np.array([j.upper for j in info.joints])
        self.max_velocity = np.array([j.max_velocity for j in info.joints])
        self.max_acceleration = np.array([j.max_acceleration for j in info.joints])

    def vector(self, values: Sequence[float], what: str) -> FloatArray:
        if len(values) != len(self.names):
            raise RobotError(
                f"{what} has {len(values)} values; the robot has {len(self.names)} joints",
                code="wrong_length",
            )
        array = np.asarray(values, dtype=float)
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise RobotError(
                f"{what} of joint {self._joint(int(bad[0]))} is not a finite number",
                code="not_finite",
            )
        return array

    def positions(self, values: Sequence[float], what: str = "position") -> FloatArray:
        q = self.vector(values, what)
        outside = np.flatnonzero(self._outside(q))
        if outside.size:
            i = int(outside[0])
            raise RobotError(
                f"{what} {q[i]:.4f} rad of joint {self._joint(i)} is outside its limits "
                f"[{self.lower[i]:.4f}, {self.upper[i]:.4f}]",
                code="position_limit",
                words=words("robot.position_limit", joint=self._joint(i)),
            )
        return q

    def velocities(self, values: Sequence[float], what: str = "velocity") -> FloatArray:
        v = self.vector(values, what)
        self._check_speed(v, what)
        return v

    def accelerations(self, values: Sequence[float], what: str) -> FloatArray:
        a = self.vector(values, what)
        self._check_within(a, self.max_acceleration, what, "rad/s²", "acceleration_limit")
        return a

    def _check_speed(self, v: FloatArray, what: str) -> None:
        self._check_within(v, self.max_velocity, what, "rad/s", "velocity_limit")

    def _check_within(
        self, values: FloatArray, limits: FloatArray, what: str, unit: str, code: str
    ) -> None:
        over = np.flatnonzero(self._over(values, limits))
        if over.size:
            i = int(over[0])
            raise RobotError(
                f"{what} {values[i]:.4f} {unit} of joint {self._joint(i)} exceeds its limit "
                f"{limits[i]:.4f} {unit}",
                code=code,
            )

    def trajectory(self, trajectory: JointTrajectory, start: FloatArray) -> CheckedTrajectory:
        """Checked all at once (a driver checks on its event loop: one waypoint at a time, a
        trajectory of a thousand held the simulated robot's loop, and its states, 130 ms);
        the first waypoint that fails is refused as the one-vector checks say."""
        points = trajectory.waypoints
        times = np.array([0.0] + [w.time_from_start for w in points])
        given = self._rows([w.position for w in points], "waypoint {} position")
        for k in _first_rows(self._outside(given)):
            self.positions(points[k].position, f"waypoint {k} position")
        positions = np.vstack([start, given])
        if points[0].time_from_start == 0.0:
            if np.max(np.abs(positions[1] - start)) > START_TOLERANCE:
                raise RobotError(
                    "the first waypoint is at t=0 but not at the robot's current position",
                    code="bad_trajectory",
                )
            times, positions = times[1:], positions[1:]
            times[0] = 0.0
        if np.any(np.diff(times) <= 0):
            raise RobotError("waypoint times must strictly increase", code="bad_trajectory")
        segment_speed = np.diff(positions, axis=0) / np.diff(times)[:, None]
        for k in _first_rows(self._over(segment_speed, self.max_velocity)):
            self._check_speed(segment_speed[k], f"segment {k} speed")
        velocities = None
        if any(w.velocity is not None for w in points):
            if not all(w.velocity is not None for w in points):
                raise RobotError(
                    "give a velocity for every waypoint or for none", code="bad_trajectory"
                )
            rows = self._rows([w.velocity or [] for w in points], "waypoint {} velocity")
            for k in _first_rows(self._over(rows, self.max_velocity)):
                self.velocities(rows[k], f"waypoint {k} velocity")
            velocities = np.vstack([np.zeros((len(times) - len(rows), len(start))), rows])
        accelerations = None
        if any(w.acceleration is not None for w in points):
            if velocities is None or not all(w.acceleration is not None for w in points):
                raise RobotError(
                    "give an acceleration for every waypoint or for none, and velocities with them",
                    code="bad_trajectory",
                )
            rows = self._rows([w.acceleration or [] for w in points], "waypoint {} acceleration")
            for k in _first_rows(self._over(rows, self.max_acceleration)):
                self.accelerations(rows[k], f"waypoint {k} acceleration")
            accelerations = np.vstack([np.zeros((len(times) - len(rows), len(start))), rows])
        return CheckedTrajectory(times, positions, velocities, accelerations)

    def _rows(self, rows: list[Sequence[float]], what: str) -> FloatArray:
        """One vector per row; the first of the wrong length or not finite is refused as
        `vector` refuses it (`what` formatted with its index)."""
        for k, row in enumerate(rows):
            if len(row) != len(self.names):
                self.vector(row, what.format(k))
        array = np.asarray(rows, dtype=float).reshape(len(rows), len(self.names))
        for k in _first_rows(~np.isfinite(array)):
            self.vector(rows[k], what.format(k))
        return array

    def _outside(self, positions: FloatArray) -> BoolArray:
        return (positions < self.lower - LIMIT_EPSILON) | (positions > self.upper + LIMIT_EPSILON)

    @staticmethod
    def _over(values: FloatArray, limits: FloatArray) -> BoolArray:
        return np.abs(values) > limits * (1 + 1e-6) + LIMIT_EPSILON

    def _joint(self, index: int) -> str:
        return f"{index + 1} ({self.names[index]})"


def _first_rows(bad: BoolArray) -> list[int]:
    """The index of the first row with any True in it (none if there is none)."""
    rows = np.flatnonzero(bad.any(axis=1))
    return [int(rows[0])] if rows.size else []
