"""A joint trajectory as the reference a driver follows, interpolated the one way every
driver and the planner share: quintic Hermite between waypoints (position, velocity and
acceleration at each), so acceleration is continuous and jerk bounded. The planner checks
its trajectory through this interpolation at the drivers' cycle, and a driver stretches a
trajectory in time (the same path, slower) when it would pass a joint's limits: a reference
is never handed to the joints one by one, each on its own profile, which would leave the
path that was checked."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openpendant.runtime.interfaces.limits import CheckedTrajectory, FloatArray
from openpendant.runtime.interfaces.robot import JointLimits, TrajectoryState, TrajectoryStatus
from openpendant.runtime.robotics.time_scaling import TimeScaling

# Points checked per segment between waypoints (8 ms apart from the planner: every 1 ms).
SAMPLES_PER_SEGMENT = 8
CHUNK = 20_000  # samples evaluated at once
STRETCH_MARGIN = 1.001

# The quintic Hermite basis on s in [0, 1] (rows: p0, v0·h, a0·h², a1·h², v1·h, p1;
# columns: the coefficients of s⁰ … s⁵).
_BASIS = np.array(
    [
        [1, 0, 0, -10, 15, -6],
        [0, 1, 0, -6, 8, -3],
        [0, 0, 0.5, -1.5, 1.5, -0.5],
        [0, 0, 0, 0.5, -1, 0.5],
        [0, 0, 0, -4, 7, -3],
        [0, 0, 0, 10, -15, 6],
    ]
)


def _derivative(basis: FloatArray) -> FloatArray:
    powers = np.arange(1, basis.shape[1])
    return np.hstack([basis[:, 1:] * powers, np.zeros((basis.shape[0], 1))])


_DERIVATIVES = [_BASIS]
for _ in range(3):
    _DERIVATIVES.append(_derivative(_DERIVATIVES[-1]))


@dataclass(frozen=True)
class Limits:
    """Per-joint velocity, acceleration and jerk limits (inf where a robot gives no jerk)."""

    velocity: FloatArray
    acceleration: FloatArray
    jerk: FloatArray

    @classmethod
    def of(cls, joints: Sequence[JointLimits]) -> Limits:
        return cls(
            np.array([j.max_velocity for j in joints]),
            np.array([j.max_acceleration for j in joints]),
            np.array([j.max_jerk or math.inf for j in joints]),
        )


class TrajectoryReference:
    """Position, velocity, acceleration and jerk of a trajectory at any time. Waypoints
    without accelerations get them estimated from their neighbours' velocities; waypoints
    without velocities are joined by straight lines."""

    def __init__(
        self,
        times: FloatArray,
        positions: FloatArray,
        velocities: FloatArray | None,
        accelerations: FloatArray | None = None,
    ) -> None:
        self.times = times
        self.positions = positions
        self.velocities = velocities
        self.duration = float(times[-1])
        self.end = positions[-1]
        if velocities is not None and accelerations is None:
            accelerations = knot_accelerations(times, velocities)
        self.accelerations = accelerations
        self._last_segment: tuple[int, FloatArray | None] = (0, None)

    @classmethod
    def of(cls, trajectory: CheckedTrajectory) -> TrajectoryReference:
        return cls(
            trajectory.times,
            trajectory.positions,
            trajectory.velocities,
            trajectory.accelerations,
        )

    def stretched(self, factor: float) -> TrajectoryReference:
        """The same path `factor` times slower."""
        if factor == 1.0:
            return self
        return TrajectoryReference(
            self.times * factor,
            self.positions,
            None if self.velocities is None else self.velocities / factor,
            None if self.accelerations is None else self.accelerations / factor**2,
        )

    def sample(self, t: float) -> tuple[FloatArray, FloatArray]:
        position, velocity, _ = self.sample_with_acceleration(t)
        return position, velocity

    def sample_with_acceleration(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Position, velocity and acceleration of the reference at time t: `sample_many`'s
        polynomial for one time, from the segment's coefficients (a driver asks every 2 ms,
        mostly within the segment it asked last)."""
        if t >= self.duration:
            return self.end.copy(), np.zeros_like(self.end), np.zeros_like(self.end)
        t = max(t, 0.0)
        times = self.times
        # One attribute, replaced whole: a reference read from two threads stays consistent.
        k, coefficients = self._last_segment
        if not times[k] <= t < times[k + 1] or coefficients is None:
            k = min(max(int(np.searchsorted(times, t, side="right")) - 1, 0), len(times) - 2)
            coefficients = self._segment_coefficients(k)
            self._last_segment = (k, coefficients)
        h = times[k + 1] - times[k]
        s = (t - times[k]) / h
        s2, s3 = s * s, s * s * s
        powers = np.array(
            [
                [1.0, s, s2, s3, s2 * s2, s3 * s2],
                [0.0, 1.0 / h, 2.0 * s / h, 3.0 * s2 / h, 4.0 * s3 / h, 5.0 * s2 * s2 / h],
                [0.0, 0.0, 2.0 / h**2, 6.0 * s / h**2, 12.0 * s2 / h**2, 20.0 * s3 / h**2],
            ]
        )
        p, v, a = powers @ coefficients
        return p, v, a

    def _segment_coefficients(self, k: int) -> FloatArray:
        """Segment k's polynomial in s (rows: the coefficients of s⁰ … s⁵, one column per
        joint)."""
        h = self.times[k + 1] - self.times[k]
        p0, p1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None or self.accelerations is None:
            zero = np.zeros_like(p0)
            return np.stack([p0, p1 - p0, zero, zero, zero, zero])
        coefficients: FloatArray = _BASIS.T @ self._terms(k, h)
        return coefficients

    def _terms(self, k: int | npt.NDArray[np.intp], h: float | FloatArray) -> FloatArray:
        """The Hermite terms of segment(s) k of length(s) h (the rows of `_BASIS`)."""
        assert self.velocities is not None
        assert self.accelerations is not None
        p, v, a = self.positions, self.velocities, self.accelerations
        return np.stack([p[k], v[k] * h, a[k] * h * h, a[k + 1] * h * h, v[k + 1] * h, p[k + 1]])

    def sample_many(self, ts: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Positions, velocities, accelerations and jerks at the times `ts` (within the
        trajectory), one row each."""
        ts = np.clip(ts, 0.0, self.duration)
        k = np.clip(np.searchsorted(self.times, ts, side="right") - 1, 0, len(self.times) - 2)
        h = (self.times[k + 1] - self.times[k])[:, None]
        s = (ts[:, None] - self.times[k][:, None]) / h
        p0, p1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None or self.accelerations is None:
            slope = (p1 - p0) / h
            zero = np.zeros_like(p0)
            return p0 + s * (p1 - p0), slope, zero, zero
        terms = self._terms(k, h)
        powers = s[:, 0][None, :] ** np.arange(6)[:, None]  # (power, sample)
        results = []
        for order, basis in enumerate(_DERIVATIVES):
            weights = basis @ powers  # (basis function, sample)
            results.append(np.einsum("bn,bnj->nj", weights, terms) / h**order)
        return results[0], results[1], results[2], results[3]

    def peak_ratio(self, limits: Limits) -> float:
        """How far the reference goes past the limits, as the factor its time must be
        stretched by to stay within them (≤ 1: within). Sampled at the same fractions of
        every segment, so a stretched reference is checked at the same points of its path."""
        if self.duration <= 0 or self.velocities is None:
            return 0.0
        fractions = np.arange(SAMPLES_PER_SEGMENT) / SAMPLES_PER_SEGMENT
        steps = np.diff(self.times)
        ts = (self.times[:-1, None] + steps[:, None] * fractions[None, :]).ravel()
        ts = np.append(ts, self.duration)
        ratio = 0.0
        for start in range(0, len(ts), CHUNK):  # bounded memory on long trajectories
            _, v, a, j = self.sample_many(ts[start : start + CHUNK])
            # Stretching time by k divides velocity by k, acceleration by k², jerk by k³.
            ratio = max(
                ratio,
                float(np.max(np.abs(v) / limits.velocity)),
                float(np.sqrt(np.max(np.abs(a) / limits.acceleration))),
                float(np.cbrt(np.max(np.abs(j) / limits.jerk))),
            )
        return ratio

    def within(self, limits: Limits) -> TrajectoryReference:
        """This reference, or the same path slowed just enough to stay within the limits."""
        ratio = self.peak_ratio(limits)
        return self.stretched(ratio * STRETCH_MARGIN) if ratio > 1.0 else self


def knot_accelerations(times: FloatArray, velocities: FloatArray) -> FloatArray:
    """Each waypoint's acceleration, from the velocities either side (one side at the ends)."""
    accelerations = np.zeros_like(velocities)
    if len(times) < 2:
        return accelerations
    accelerations[1:-1] = (velocities[2:] - velocities[:-2]) / (times[2:] - times[:-2])[:, None]
    accelerations[0] = (velocities[1] - velocities[0]) / (times[1] - times[0])
    accelerations[-1] = (velocities[-1] - velocities[-2]) / (times[-1] - times[-2])
    return accelerations


@dataclass
class RunningTrajectory:
    """A trajectory a driver is following: its reference and its own clock, which runs at
    the speed override (or slows to a stop when paused) through the time scaling."""

    id: str
    reference: TrajectoryReference
    t: float = 0.0  # where on the trajectory's own clock the reference is
    state: TrajectoryState = TrajectoryState.running
    message: str = ""

    def status(self) -> TrajectoryStatus:
        progress = 1.0 if self.reference.duration == 0 else min(self.t / self.reference.duration, 1)
        return TrajectoryStatus(
            id=self.id, state=self.state, progress=progress, message=self.message
        )

    def advance(
        self, scaling: TimeScaling, speed_ratio: float, dt: float
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """One cycle of the clock: the reference's position, velocity and acceleration at
        its new time, scaled by the clock's rate."""
        _, planned, planned_acceleration = self.reference.sample_with_acceleration(self.t)
        target = 0.0 if self.state is TrajectoryState.paused else speed_ratio
        before = scaling.rate
        scaling.step(target, planned, planned_acceleration, dt)
        rate, rate_speed = scaling.rate, scaling.rate_speed
        self.t += dt * 0.5 * (before + rate)  # the clock's advance over the cycle
        position, velocity, acceleration = self.reference.sample_with_acceleration(self.t)
        return position, velocity * rate, acceleration * rate * rate + velocity * rate_speed

    @property
    def at_end(self) -> bool:
        return self.t >= self.reference.duration
