"""Online trajectory generation with ruckig: every cycle the setpoint moves one step toward
the current target without exceeding the joint velocity, acceleration and jerk limits. The
joint-level controller of every simulated arm (the simulated robot, the UR emulator): in
the robotics core, so that no driver takes it from another."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from ruckig import (
    ControlInterface,
    InputParameter,
    OutputParameter,
    Result,
    Ruckig,
    RuckigError,
    Synchronization,
    Trajectory,
)

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import JointLimits

_POSITION = ControlInterface.Position
_VELOCITY = ControlInterface.Velocity


# A jogging joint this close in time to its limit aims at the limit to stop exactly there.
LIMIT_LOOKAHEAD = 0.5  # s
SETTLED_POSITION = 1e-7  # rad
SETTLED_VELOCITY = 1e-6  # rad/s
# A reference is followed as it is when its next state is where its motion leads (within
# this, rad) and its jerk within the limit (this much over it: the interpolation's own).
FOLLOW_TOLERANCE = 1e-5
FOLLOW_JERK_SLACK = 1.05
FOLLOW_LIMIT_SLACK = 1.0 + 1e-6  # float noise on a reference at its limit
# A planned trajectory's reference was checked at 8 points of each 8 ms segment; between
# them it can pass a limit by a fraction of a percent, which is no reason to leave its path.
REFERENCE_SLACK = 1.01
COLLINEAR = 1e-9  # relative: a reference's vector this close to a line is on it
LINE_DRIFT = 1e-6  # rad, rad/s: the arm this close to a reference's line is on it
# rad/s and rad/s²: a holding joint slower than this, and slowing no faster, is at rest.
AT_REST = 1e-9


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
        self.max_jerk = np.array([j.max_jerk or math.inf for j in joints])
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
        # The limit guard plans, offline, the fastest stop from each new state.
        self._brake = Ruckig(n)
        self._brake_in = InputParameter(n)
        self._brake_in.control_interface = _VELOCITY
        self._brake_in.synchronization = Synchronization.No
        self._brake_in.target_velocity = [0.0] * n
        self._brake_in.target_acceleration = [0.0] * n
        self._brake_in.max_velocity = self.max_velocity.tolist()
        self._brake_in.max_acceleration = self.max_acceleration.tolist()
        self._brake_in.max_jerk = self._in.max_jerk
        self._brake_path = Trajectory(n)
        # One coordinate along a straight line in joint space (`_step_along`).
        self._line = Ruckig(1, dt)
        self._line_in = InputParameter(1)
        self._line_out = OutputParameter(1)
        # And a stop along such a line (`_brake_along`).
        self._brake_line = Ruckig(1, dt)
        self._brake_line_in = InputParameter(1)
        self._brake_line_in.control_interface = _VELOCITY
        self._brake_line_in.target_velocity = [0.0]
        self._brake_line_in.target_acceleration = [0.0]
        self._brake_line_out = OutputParameter(1)
        self.guard_trips = 0

    @property
    def moving(self) -> bool:
        return bool(
            np.any(np.abs(self.velocity) > 1e-9) or np.any(np.abs(self.acceleration) > 1e-9)
        )

    def settled(self, target: FloatArray) -> bool:
        """At `target` and practically still (the tracker can creep the last nanometres)."""
        return bool(
            np.max(np.abs(self.position - target)) < SETTLED_POSITION
            and np.max(np.abs(self.velocity)) < SETTLED_VELOCITY
        )

    def place(self, position: FloatArray) -> None:
        """At `position`, at rest, at once (a simulator's set-up, not a motion)."""
        n = len(self.position)
        self.position = np.array(position, dtype=float)
        self.velocity = np.zeros(n)
        self.acceleration = np.zeros(n)
        self._in.current_position = self.position.tolist()
        self._in.current_velocity = [0.0] * n
        self._in.current_acceleration = [0.0] * n

    def hold(self) -> None:
        """Come to a stop (halt), then stay there: every joint slows down in step, as fast
        as the slowest one allows, so the robot brakes along its path. Braking each joint
        as fast as it can would turn the motion: joints whose motions cancel at the TCP
        stop at different times, and the TCP could speed up while the robot halts."""
        if np.abs(self.velocity).max() < AT_REST and np.abs(self.acceleration).max() < AT_REST:
            # At rest it stays: the generator would compute just that, 500 times a second,
            # and never quite reach zero (it leaves 1e-25 rad/s behind): dropped here.
            if self.velocity.any() or self.acceleration.any():
                self.place(self.position)
            return
        if self._brake_along():
            return
        n = len(self.position)
        self._run(
            [_VELOCITY] * n,
            self.position,
            np.zeros(n),
            self.max_velocity,
            synchronization=Synchronization.Phase,
        )

    def _brake_along(self) -> bool:
        """An arm moving along one straight line in joint space (a planned joint move, a
        joint jog) stops on it, with one generator for the line's coordinate. ruckig's phase
        synchronization of a velocity-interface stop meant the same but left the line: a
        Move to whose stream stalled past its timeout (a loaded machine) was halted off its
        line and went on 0.0035 rad off it (a simulation of such stalls: 0.01-0.08 rad,
        tests/unit/test_tracker_line.py). False when
        the arm's velocity and acceleration are not on one line, or this stop could not
        keep a joint within its limits: then the joints stop in step as before."""
        speed = float(np.linalg.norm(self.velocity))
        # The line is the velocity's; at the instant a joint move turns from speeding up to
        # slowing down, or starts, the acceleration's.
        basis = self.velocity if speed > 1e-12 else self.acceleration
        length = float(np.linalg.norm(basis))
        if length < 1e-12:
            return False
        d = basis / length
        if (
            _across(self.acceleration, d) > LINE_DRIFT * 100
            or _across(self.velocity, d) > LINE_DRIFT
        ):
            return False
        top_speed, top_acceleration, top_jerk = self._line_limits(d)
        line = self._brake_line_in
        line.current_position = [0.0]
        line.current_velocity = [float(self.velocity @ d)]
        line.current_acceleration = [float(self.acceleration @ d)]
        line.max_velocity = [top_speed]
        line.max_acceleration = [top_acceleration]
        line.max_jerk = [top_jerk]
        try:
            result = self._brake_line.update(line, self._brake_line_out)
        except (RuckigError, ValueError):
            return False
        if result not in (Result.Working, Result.Finished):
            return False
        out = self._brake_line_out
        position = self.position + d * out.new_position[0]
        velocity = d * out.new_velocity[0]
        acceleration = d * out.new_acceleration[0]
        if self._cannot_stop_from(position, velocity, acceleration).any():
            return False
        self._take(position, velocity, acceleration)
        return True

    def step_velocity(self, velocity: FloatArray) -> None:
        """Move each joint at its commanded velocity, every joint's change of speed in step
        (phase-synchronized), so the TCP keeps the direction the velocities give it: each
        on its own profile, a reactive move speeding up from rest left its line by 13 mm.
        Near its position limit a moving joint aims at the limit instead, so it stops
        exactly there rather than running through; far from it (the lookahead), it simply
        follows the velocity."""
        speed = np.minimum(np.abs(velocity), self.max_velocity)
        moving = speed > 1e-9
        limit = np.where(velocity > 0, self.upper, self.lower)
        room = np.abs(limit - self.position)
        braking = speed * speed / (2.0 * self.max_acceleration)
        near = moving & (room < speed * LIMIT_LOOKAHEAD + braking + 0.01)
        interfaces = [_POSITION if n else _VELOCITY for n in near]
        target_velocity = np.where(near, 0.0, np.sign(velocity) * speed)
        self._run(
            interfaces,
            np.where(near, limit, self.position),
            target_velocity,
            np.where(near, speed, self.max_velocity),
            synchronization=Synchronization.No if near.any() else Synchronization.Phase,
        )

    def step_toward(self, target: FloatArray, max_velocity: FloatArray) -> None:
        """Toward `target`, to stop there, no joint faster than `max_velocity` (a point-to-
        point move: each joint on its own profile)."""
        n = len(target)
        clipped = np.clip(target, self.lower, self.upper)
        self._run(
            [_POSITION] * n, clipped, np.zeros(n), np.minimum(max_velocity, self.max_velocity)
        )

    def step_position(
        self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray | None = None
    ) -> None:
        """Track a moving reference (position, and its velocity and acceleration)."""
        target = np.clip(position, self.lower, self.upper)
        # A reference still heading for a limit must be able to stop before it; half the
        # acceleration limit leaves room for the jerk-limited ramps.
        room = np.where(velocity > 0, self.upper - target, target - self.lower)
        stop_speed = np.sqrt(self.max_acceleration * np.maximum(room, 0.0))
        bound = np.minimum(stop_speed, self.max_velocity)
        # Bounds applied to the whole vector, not joint by joint: a reference along a line
        # in joint space stays along it, which the phase synchronization below keeps.
        capped = np.clip(velocity * _within(velocity, bound), -bound, bound)
        accel = np.zeros_like(position) if acceleration is None else acceleration
        if np.any(capped != velocity):
            accel = np.zeros_like(accel)
        else:
            accel = accel * _within(accel, self._feasible_acceleration_bound(capped))
        if acceleration is not None and self._follows(target, capped, accel):
            return
        if self._step_along(target, capped, accel):
            return
        self._run(
            [_POSITION] * len(position),
            target,
            capped,
            self.max_velocity,
            accel,
            synchronization=Synchronization.Phase,
        )

    def follow(self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray) -> None:
        """Follow a planned trajectory's reference (already within the limits, or slowed
        along its path until it is): exactly, as a controller interpolating its own
        trajectory does. Its jerk is the planner's and the time scaling's to keep: a jerk
        a little over the limit for a cycle (a change of speed override) is no reason to
        leave the path. Only a reference that jumps, passes a speed or acceleration limit,
        or could not stop before a position limit is handed to ruckig."""
        if not self._follows(
            position, velocity, acceleration, jerk_slack=math.inf, limit_slack=REFERENCE_SLACK
        ):
            self.step_position(position, velocity, acceleration)

    def _follows(
        self,
        position: FloatArray,
        velocity: FloatArray,
        acceleration: FloatArray,
        jerk_slack: float = FOLLOW_JERK_SLACK,
        limit_slack: float = FOLLOW_LIMIT_SLACK,
    ) -> bool:
        """A smooth reference within the limits is followed exactly, as a controller
        interpolating its own trajectory would; asking ruckig to reach each new reference
        state as fast as it can instead let the joints pick different profiles and leave the
        path. A reference that jumps, or would pass a limit, goes to ruckig."""
        dt = self.dt
        expected = self.position + 0.5 * dt * (self.velocity + velocity)
        jerk = (acceleration - self.acceleration) / dt
        smooth = (
            (np.abs(position - expected) <= FOLLOW_TOLERANCE).all()
            and (np.abs(velocity) <= self.max_velocity * limit_slack).all()
            and (np.abs(acceleration) <= self.max_acceleration * limit_slack).all()
            and (np.abs(jerk) <= self.max_jerk * jerk_slack).all()
        )
        if not smooth or self._cannot_stop_from(position, velocity, acceleration).any():
            return False
        self._take(position, velocity, acceleration)
        return True

    def _step_along(
        self, target: FloatArray, velocity: FloatArray, acceleration: FloatArray
    ) -> bool:
        """A reference moving along one straight line in joint space, with the arm on it (a
        joint move, planned on that line and streamed): one step along the line, with one
        generator for the line's own coordinate, so every joint stays on it. (Phase
        synchronization meant the same, but ruckig left the line by 0.006 rad tracking a
        streamed joint move, where the limits made another joint the slowest.) False when
        the reference or the arm is not on one line: then the joints are tracked as usual."""
        moving_reference = float(np.linalg.norm(velocity)) > 1e-9
        basis = velocity if moving_reference else target - self.position
        length = float(np.linalg.norm(basis))
        if length < 1e-12:
            return False
        d = basis / length

        def across(vector: FloatArray) -> float:
            return _across(vector, d)

        if across(acceleration) > COLLINEAR * (1.0 + float(np.linalg.norm(acceleration))):
            return False
        # The arm's own state on the same line, but for the float drift of its steps.
        if max(across(target - self.position), across(self.velocity)) > LINE_DRIFT:
            return False
        if across(self.acceleration) > LINE_DRIFT * 100:
            return False
        top_speed, top_acceleration, top_jerk = self._line_limits(d)
        speed = float(np.clip(velocity @ d, -top_speed, top_speed))
        room = top_speed - abs(speed)
        reach = min(0.9 * top_acceleration, math.sqrt(2.0 * top_jerk * 0.9 * room))
        line = self._line_in
        line.current_position = [float((self.position - target) @ d)]  # the target at 0
        line.current_velocity = [float(self.velocity @ d)]
        line.current_acceleration = [float(self.acceleration @ d)]
        line.target_position = [0.0]
        line.target_velocity = [speed]
        line.target_acceleration = [float(np.clip(acceleration @ d, -reach, reach))]
        line.max_velocity = [top_speed]
        line.max_acceleration = [top_acceleration]
        line.max_jerk = [top_jerk]
        try:
            result = self._line.update(line, self._line_out)
        except (RuckigError, ValueError):
            return False
        if result not in (Result.Working, Result.Finished):
            return False
        out = self._line_out
        position = target + d * out.new_position[0]
        velocity_now = d * out.new_velocity[0]
        acceleration_now = d * out.new_acceleration[0]
        if self._cannot_stop_from(position, velocity_now, acceleration_now).any():
            return False  # the joint-limit guard decides, joint by joint
        self._take(position, velocity_now, acceleration_now)
        return True

    def _line_limits(self, d: FloatArray) -> tuple[float, float, float]:
        """The speed, acceleration and jerk along the unit joint-space direction `d` that keep
        every joint within its own limits."""
        share = np.abs(d)
        moving = share > 1e-12
        return (
            float(np.min(self.max_velocity[moving] / share[moving])),
            float(np.min(self.max_acceleration[moving] / share[moving])),
            float(np.min(self.max_jerk[moving] / share[moving])),
        )

    def _take(self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray) -> None:
        """This state is the arm's, and the generator's next start."""
        self.position = position.astype(float)
        self.velocity = velocity.astype(float)
        self.acceleration = acceleration.astype(float)
        self._in.current_position = self.position.tolist()
        self._in.current_velocity = self.velocity.tolist()
        self._in.current_acceleration = self.acceleration.tolist()

    def _feasible_acceleration_bound(self, velocity: FloatArray) -> FloatArray:
        """Arriving with the reference's acceleration avoids a lag. But jerk is limited, so a
        target state with acceleration a was reached through a velocity a²/2j away from its
        own; ruckig rejects targets where that passes the velocity limit."""
        room = np.maximum(self.max_velocity - np.abs(velocity), 0.0)
        reachable = np.sqrt(2.0 * self.max_jerk * 0.9 * room)
        bound: FloatArray = np.minimum(0.9 * self.max_acceleration, reachable)
        return bound

    def _run(
        self,
        interfaces: list[ControlInterface],
        target_position: FloatArray,
        target_velocity: FloatArray,
        max_velocity: FloatArray,
        target_acceleration: FloatArray | None = None,
        synchronization: Synchronization = Synchronization.No,
    ) -> None:
        accel = np.zeros(len(interfaces)) if target_acceleration is None else target_acceleration
        self._in.synchronization = synchronization
        self._update(interfaces, target_position, target_velocity, max_velocity, accel)
        unsafe = self._cannot_stop_in_limits()
        if unsafe.any():
            # Like a controller's joint-limit braking: those joints stop now, from the
            # previous state, which was checked to have a stop within the limits.
            self.guard_trips += 1
            self._in.synchronization = Synchronization.No  # the limits win over the path
            interfaces = [_VELOCITY if u else i for u, i in zip(unsafe, interfaces, strict=True)]
            self._update(
                interfaces,
                target_position,
                np.where(unsafe, 0.0, target_velocity),
                max_velocity,
                np.where(unsafe, 0.0, accel),
            )
        self._out.pass_to_input(self._in)
        self.position = np.array(self._out.new_position)
        self.velocity = np.array(self._out.new_velocity)
        self.acceleration = np.array(self._out.new_acceleration)

    def _update(
        self,
        interfaces: list[ControlInterface],
        target_position: FloatArray,
        target_velocity: FloatArray,
        max_velocity: FloatArray,
        target_acceleration: FloatArray,
    ) -> None:
        self._in.per_dof_control_interface = interfaces
        self._in.target_position = target_position.tolist()
        self._in.target_velocity = target_velocity.tolist()
        self._in.target_acceleration = target_acceleration.tolist()
        self._in.max_velocity = max_velocity.tolist()
        try:
            result = self._otg.update(self._in, self._out)
        except (RuckigError, ValueError) as exc:
            # ValueError: the binding cannot map some error codes back to its Result enum.
            raise TrackerError(f"trajectory generation failed: {str(exc).strip()}") from exc
        if result not in (Result.Working, Result.Finished):
            raise TrackerError(f"trajectory generation failed: {result}")

    def _cannot_stop_in_limits(self) -> npt.NDArray[np.bool_]:
        """Joints whose fastest stop from the proposed new state would pass a limit (and
        move further out than they already are)."""
        return self._cannot_stop_from(
            np.array(self._out.new_position),
            np.array(self._out.new_velocity),
            np.array(self._out.new_acceleration),
        )

    def _cannot_stop_from(
        self, position: FloatArray, velocity: FloatArray, acceleration: FloatArray
    ) -> npt.NDArray[np.bool_]:
        self._brake_in.current_position = position.tolist()
        self._brake_in.current_velocity = velocity.tolist()
        self._brake_in.current_acceleration = acceleration.tolist()
        try:
            self._brake.calculate(self._brake_in, self._brake_path)
        except RuckigError:
            return np.ones(len(position), dtype=bool)
        # Where each joint comes to rest. A time-optimal brake to zero velocity never turns
        # back, so its end is its extreme. (ruckig 0.19's position_extrema report 0 for a
        # joint whose stop takes no time: a joint whose range excludes 0, such as the Panda's
        # joint 4, then seemed unable to stop anywhere, and never moved.)
        end = np.array(self._brake_path.at_time(self._brake_path.duration)[0])
        low, high = np.minimum(position, end), np.maximum(position, end)
        eps = 1e-9
        result: npt.NDArray[np.bool_] = (high > np.maximum(self.upper, position) + eps) | (
            low < np.minimum(self.lower, position) - eps
        )
        return result


def _across(vector: FloatArray, d: FloatArray) -> float:
    """How far `vector` is off the line of the unit vector `d`."""
    return float(np.linalg.norm(vector - float(vector @ d) * d))


def _within(vector: FloatArray, bound: FloatArray) -> float:
    """The largest factor up to 1 that brings every element of `vector` within ±`bound`."""
    over = np.abs(vector) > bound
    if not np.any(over):
        return 1.0
    return float(np.min(bound[over] / np.abs(vector[over])))
