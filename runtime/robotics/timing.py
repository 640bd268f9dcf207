"""Time-scaling of a sampled joint path: ruckig plans the path parameter u (arc length)
from rest to rest under bounds on u̇, ü and the jerk of u, chosen from the path's
derivatives (a C² spline through the samples) so that no joint can exceed its velocity,
acceleration or jerk limit; the result is checked as the drivers will interpolate it
(`openpendant.runtime.robotics.reference`), and slowed as a whole when needed."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Trajectory
from scipy.interpolate import CubicSpline

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.reference import STRETCH_MARGIN, Limits, TrajectoryReference

SAMPLE_PERIOD = 0.008  # s between the trajectory points sent to the driver
MAX_SLOWDOWNS = 12


@dataclass(frozen=True)
class TimedPath:
    times: FloatArray
    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def reference(self) -> TrajectoryReference:
        """The trajectory as a driver interpolates it."""
        return TrajectoryReference(self.times, self.positions, self.velocities, self.accelerations)

    def stretched(self, factor: float) -> TimedPath:
        """The same path `factor` times slower."""
        return TimedPath(
            self.times * factor,
            self.positions,
            self.velocities / factor,
            self.accelerations / factor**2,
        )

    def within(self, limits: Limits) -> TimedPath:
        """This trajectory, or the same path slowed just enough that the drivers'
        interpolation of it stays within the limits."""
        ratio = self.reference().peak_ratio(limits)
        return self.stretched(ratio * STRETCH_MARGIN) if ratio > 1.0 else self

    def then(self, other: TimedPath) -> TimedPath:
        """This path followed by `other` (which starts where this one ends, at rest)."""
        offset = self.times[-1]
        return TimedPath(
            np.concatenate([self.times, other.times[1:] + offset]),
            np.vstack([self.positions, other.positions[1:]]),
            np.vstack([self.velocities, other.velocities[1:]]),
            np.vstack([self.accelerations, other.accelerations[1:]]),
        )


def at_rest(position: FloatArray) -> TimedPath:
    zeros = np.zeros((1, position.size))
    return TimedPath(np.zeros(1), position[None, :].copy(), zeros, zeros.copy())


def time_scale(
    samples: FloatArray,
    info: RobotInfo,
    *,
    speed: float = 1.0,
    acceleration: float = 1.0,
    kinematics: Kinematics | None = None,
    tcp_cap: float | None = None,
) -> TimedPath:
    """A trajectory along `samples` (rows of joint positions) from rest to rest."""
    if len(samples) < 2 or np.max(np.abs(samples - samples[0])) < 1e-12:
        return at_rest(samples[-1])
    # The parameter is the joint-space arc length, in units of the mean sample step: uneven
    # sample spacing (a Bézier corner, a slow stretch of IK) would otherwise show up as
    # curvature and slow the whole path down.
    steps = np.linalg.norm(np.diff(samples, axis=0), axis=1)
    keep = np.concatenate([[True], steps > 1e-12])
    samples, steps = samples[keep], steps[steps > 1e-12]
    u = np.concatenate([[0.0], np.cumsum(steps)]) / np.mean(steps)
    spline = CubicSpline(u, samples, axis=0)
    dense = np.linspace(0, u[-1], 4 * len(samples))
    m1 = np.max(np.abs(spline(dense, 1)), axis=0) + 1e-12
    m2 = np.max(np.abs(spline(dense, 2)), axis=0)
    m3 = np.max(np.abs(spline(dense, 3)), axis=0)
    v = np.array([j.max_velocity for j in info.joints]) * speed
    a = np.array([j.max_acceleration for j in info.joints]) * acceleration
    jerk = np.array([j.max_jerk or math.inf for j in info.joints]) * acceleration
    # |q'| u̇ ≤ v;  |q'| ü + |q''| u̇² ≤ a;  |q'| u⃛ + 3|q''| u̇ ü + |q'''| u̇³ ≤ jerk.
    u_v = min(float(np.min(v / m1)), float(np.min(np.sqrt(a / (2 * m2 + 1e-12)))))
    u_a = float(np.min((a - m2 * u_v**2) / m1))
    # The jerk bound is kept from vanishing on tight curves (the floor); velocity and
    # acceleration, the limits that matter to the drives, are verified on the result.
    u_j = float(np.min(np.maximum(jerk - 3 * m2 * u_v * u_a - m3 * u_v**3, jerk / 4) / m1))
    limits = Limits(v, a, jerk)
    scale = 1.0
    for _ in range(MAX_SLOWDOWNS):
        timed = _scaled(spline, u[-1], u_v * scale, u_a * scale**2, u_j * scale**3)
        excess = _excess(timed, limits, kinematics, tcp_cap)
        if excess <= 1.0:
            return timed
        scale *= 0.97 / excess
    return timed


def _scaled(spline: CubicSpline, end: float, vmax: float, amax: float, jmax: float) -> TimedPath:
    otg = Ruckig(1)
    inp = InputParameter(1)
    inp.current_position = [0.0]
    inp.target_position = [end]
    inp.max_velocity = [vmax]
    inp.max_acceleration = [amax]
    inp.max_jerk = [jmax] if math.isfinite(jmax) and jmax > 0 else [math.inf]
    trajectory = Trajectory(1)
    result = otg.calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"cannot time the path: {result}")
    duration = float(trajectory.duration)
    count = max(2, int(np.ceil(duration / SAMPLE_PERIOD)) + 1)
    times = np.linspace(0.0, duration, count)
    states = [trajectory.at_time(float(t)) for t in times]
    s = np.clip(np.array([p[0][0] for p in states]), 0.0, end)
    s_dot = np.array([p[1][0] for p in states])
    s_ddot = np.array([p[2][0] for p in states])
    s[-1], s_dot[-1], s_dot[0], s_ddot[-1], s_ddot[0] = end, 0.0, 0.0, 0.0, 0.0
    positions = spline(s)
    velocities = spline(s, 1) * s_dot[:, None]
    accelerations = spline(s, 2) * (s_dot**2)[:, None] + spline(s, 1) * s_ddot[:, None]
    return TimedPath(times, positions, velocities, accelerations)


def _excess(
    timed: TimedPath,
    limits: Limits,
    kinematics: Kinematics | None,
    tcp_cap: float | None,
) -> float:
    """The factor by which the trajectory must be slowed so that no joint's speed,
    acceleration or jerk (nor the TCP's speed) passes its limit, measured on the trajectory
    as the drivers interpolate it, at their cycle."""
    dt = np.diff(timed.times)[:, None]
    speed = np.abs(np.diff(timed.positions, axis=0)) / dt
    ratio = float(np.max(speed / limits.velocity))
    ratio = max(ratio, timed.reference().peak_ratio(limits))
    if kinematics is not None and tcp_cap is not None:
        step = max(1, len(timed.times) // 200)
        peak = max(
            float(np.linalg.norm(kinematics.jacobian(q)[:3] @ qd))
            for q, qd in zip(timed.positions[::step], timed.velocities[::step], strict=True)
        )
        ratio = max(ratio, peak / tcp_cap)
    return ratio
