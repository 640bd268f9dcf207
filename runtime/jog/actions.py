"""What one press of a jog button does, cycle by cycle: each tick turns the robot's latest
state into the next streamed command."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable

import numpy as np
import pinocchio as pin

from openpendant.runtime.clients.input import InputClient
from openpendant.runtime.clients.robot import Halt, Streamed
from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    FreedriveCommand,
    PositionCommand,
    RobotState,
    VelocityCommand,
)
from openpendant.runtime.robotics.joint_move import PlannedMove
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.path_monitor import PathMonitor
from openpendant.runtime.robotics.velocity import VelocityController

# The driver halts on its own if the stream stops for this long (the deadman's backstop).
COMMAND_TIMEOUT = 0.2
ARRIVED = 1e-7  # rad: a planned move is done when every joint is this close to its goal
# Cartesian jog holds its line and orientation: error fed back at this rate (1/s).
CORRECTION_GAIN = 10.0
RAMP = 0.15  # s from standstill to jog speed and back
MOUSE_LAG = 0.005  # m: how far off its course the 3D mouse's TCP is pulled back from, at most
MOUSE_LAG_ANGLE = 0.05  # rad: the same for its orientation


class Action(ABC):
    mode: CommandMode

    def __init__(self, press: str) -> None:
        self.press = press
        self.done = False
        self.outcome = ("done", "arrived")  # what to report when done
        self.ticks = 0
        self.generation = -1  # the robot link it runs on (set when it starts)
        self.streamed = False  # a command of its went out: the robot may move on it

    def release(self, now: float) -> bool:
        """The button was let go. True when the action winds down by itself (it then ends
        with `done`); False when the caller must stop the robot."""
        return False

    def tag(self) -> str:
        self.ticks += 1
        return f"{self.press}#{self.ticks}"

    @abstractmethod
    def tick(self, state: RobotState, now: float) -> Streamed | None:
        """The next command, or None to send nothing this cycle."""


def override(asked: float, state: RobotState) -> float:
    """The fraction of the jog speed a press runs at: what it asked, never more than the
    robot's speed override as it is now (a client's own figure does not raise it, and an
    override lowered by anyone slows a held jog, a Move to or a step). An override the driver
    reports out of [0, 1] or not a number counts as 0."""
    ratio = state.speed_ratio
    return min(asked, ratio) if math.isfinite(ratio) and 0.0 <= ratio <= 1.0 else 0.0


def scaled_cap(tcp_cap: float | None, fraction: float) -> float | None:
    """The TCP speed cap at an override: 10 % of the manual mode's 250 mm/s is 25 mm/s, as
    for a program's moves, whose trajectories the override slows."""
    return None if tcp_cap is None else tcp_cap * fraction


class RampedJog(Action):
    """A continuous jog whose speed ramps up after the press and down after the release,
    so every joint changes speed together and the TCP keeps to its path."""

    mode = CommandMode.velocity_command

    def __init__(self, press: str) -> None:
        super().__init__(press)
        self.began: float | None = None
        self.released: tuple[float, float] | None = None  # (time, level then)
        self.previous: FloatArray | None = None  # the last velocity commanded

    def level(self, now: float) -> float:
        if self.began is None:
            self.began = now
        rising = min(1.0, (now - self.began) / RAMP)
        if self.released is None:
            return rising
        at, level = self.released
        return max(0.0, level * (1.0 - (now - at) / RAMP))

    def release(self, now: float) -> bool:
        if self.released is None:
            self.released = (now, self.level(now))
        return True

    def last(self, state: RobotState) -> FloatArray:
        if self.previous is None:
            return np.array(state.joint_velocity)
        return self.previous

    def command(self, velocity: FloatArray, now: float) -> VelocityCommand:
        settled = not np.any(np.abs(velocity) > 1e-6)
        overdue = self.released is not None and now - self.released[0] > RAMP + 0.5
        if self.released is not None and self.level(now) == 0.0 and (settled or overdue):
            velocity = np.zeros_like(velocity)
            self.done = True
            self.outcome = ("stopped", "released")
        self.previous = velocity
        return VelocityCommand(velocity=velocity.tolist(), timeout=COMMAND_TIMEOUT, tag=self.tag())


class JointVelocityJog(RampedJog):
    def __init__(
        self,
        press: str,
        controller: VelocityController,
        velocity: FloatArray,
        tcp_cap: float | None,
        speed: float = 1.0,
    ) -> None:
        """`velocity` and `tcp_cap` at 100 %; `speed` the fraction of them asked."""
        super().__init__(press)
        self.controller = controller
        self.velocity = velocity
        self.tcp_cap = tcp_cap
        self.speed = speed

    def tick(self, state: RobotState, now: float) -> VelocityCommand:
        q = np.array(state.joint_position_command)
        fraction = override(self.speed, state)
        wanted = self.velocity * self.level(now) * fraction
        cap = scaled_cap(self.tcp_cap, fraction)
        step = self.controller.from_joint_velocity(q, wanted, cap, self.last(state))
        return self.command(step.velocity, now)


class TwistJog(RampedJog):
    """Cartesian jog along or about one axis of the base frame, or of the tool frame as it
    was at the press. The pose at the press is the reference: the TCP keeps to the line (or
    the point) and the orientation it started with, in every direction not being jogged, so
    velocity ramps and a slightly old state cannot add up to drift."""

    def __init__(
        self,
        press: str,
        controller: VelocityController,
        kinematics: Kinematics,
        twist: FloatArray,
        frame: str,
        tcp_cap: float | None,
        speed: float = 1.0,
    ) -> None:
        """`twist` and `tcp_cap` at 100 %; `speed` the fraction of them asked."""
        super().__init__(press)
        self.controller = controller
        self.kinematics = kinematics
        self.local_twist = twist
        self.frame = frame
        self.tcp_cap = tcp_cap
        self.speed = speed
        self.start: pin.SE3 | None = None
        self.twist = twist

    def _begin(self, q: FloatArray) -> None:
        self.start = self.kinematics.tcp(q)
        if self.frame == "tool":
            rotation = self.start.rotation
            self.twist = np.concatenate(
                (rotation @ self.local_twist[:3], rotation @ self.local_twist[3:])
            )

    def correction(self, current: pin.SE3) -> FloatArray:
        assert self.start is not None
        start = self.start
        linear, angular = self.twist[:3], self.twist[3:]
        if np.any(linear):
            axis = linear / np.linalg.norm(linear)
            along = start.translation + axis * float(
                axis @ (current.translation - start.translation)
            )
            position_error = along - current.translation
            rotation_error = pin.log3(start.rotation @ current.rotation.T)
        else:
            axis = angular / np.linalg.norm(angular)
            position_error = start.translation - current.translation
            turned = float(axis @ pin.log3(current.rotation @ start.rotation.T))
            intended = pin.exp3(axis * turned) @ start.rotation
            rotation_error = pin.log3(intended @ current.rotation.T)
        return CORRECTION_GAIN * np.concatenate((position_error, rotation_error))

    def tick(self, state: RobotState, now: float) -> VelocityCommand:
        q = np.array(state.joint_position_command)
        if self.start is None:
            self._begin(q)
        fraction = override(self.speed, state)
        twist = self.twist * self.level(now) * fraction + self.correction(self.kinematics.tcp(q))
        cap = scaled_cap(self.tcp_cap, fraction)
        step = self.controller.from_twist(q, twist, cap, self.last(state))
        return self.command(step.velocity, now)


# How fast a held planned move follows an override lowered (or raised again) while it runs:
# its clock's rate changes by at most this per second, so the change adds at most the
# move's own speed times this to its accelerations (a step from 100 % to 10 % takes 0.9 s).
RATE_CHANGE = 1.0
LATE_TICK = 0.03  # s of the plan's time a tick advances at most (three of jog's periods)


class PlannedMoveAction(Action):
    """Follow a planned move by streaming its positions; the stream stopping halts it. With
    a path monitor, the arm leaving the path that was checked ends it (PathDeviation).

    It runs on a clock of its own: at the speed it was planned at (`speed`, the override
    then), slower while the robot's override is lower than that, never faster; along the
    same positions, so the path checked is the path run."""

    mode = CommandMode.position_command

    def __init__(
        self,
        press: str,
        move: PlannedMove,
        monitor: PathMonitor | None = None,
        speed: float = 1.0,
    ) -> None:
        super().__init__(press)
        self.move = move
        self.monitor = monitor
        self.speed = speed
        self.progress = 0.0  # s of the plan's time reached
        self.rate = 1.0  # s of the plan's time per second now
        self.last: float | None = None

    def tick(self, state: RobotState, now: float) -> PositionCommand:
        if self.monitor is not None:
            self.monitor.check(np.array(state.joint_position))
        # A late tick (the service held up) does not jump the stream ahead by the time it
        # lost: the plan's clock runs late instead, so no sample leaps towards the goal.
        dt = 0.0 if self.last is None else min(max(0.0, now - self.last), LATE_TICK)
        self.last = now
        wanted = min(1.0, override(1.0, state) / self.speed) if self.speed > 0 else 1.0
        change = RATE_CHANGE * dt
        self.rate += min(change, max(-change, wanted - self.rate))
        self.progress += self.rate * dt
        t = self.progress
        position, velocity = self.move.sample(t)
        velocity = velocity * self.rate
        if t >= self.move.duration:
            position, velocity = self.move.goal, np.zeros_like(self.move.goal)
            reached = np.abs(np.array(state.joint_position_command) - self.move.goal)
            still = np.all(np.abs(state.joint_velocity) < 1e-9)
            self.done = bool(np.all(reached < ARRIVED) and still)
        return PositionCommand(
            position=position.tolist(),
            velocity=velocity.tolist(),
            timeout=COMMAND_TIMEOUT,
            tag=self.tag(),
        )


class FreedriveHold(Action):
    """The arm held free to be moved by hand (a UR's teach mode) for as long as the button
    is: each cycle renews it; when the commands stop, the robot holds where it is."""

    mode = CommandMode.freedrive

    def tick(self, state: RobotState, now: float) -> FreedriveCommand:
        return FreedriveCommand(timeout=COMMAND_TIMEOUT, tag=self.tag())


class MouseJog(Action):
    """Jogging with a 3D mouse: its deflection is the hold-to-run. The robot halts, and the
    binding ends, when the mouse stops reporting while deflected (a mouse reports
    continuously while deflected, so silence means stuck). A mouse that goes away (unplugged,
    its driver restarting) halts the robot and the binding waits for it: it drives again
    only after its cap was seen at rest, so nothing resumes without a new deflection."""

    mode = CommandMode.velocity_command

    def __init__(
        self,
        press: str,
        controller: VelocityController,
        kinematics: Kinematics,
        feed: InputClient,
        *,
        cartesian: bool,
        frame: str,
        joints: list[int],
        speeds: FloatArray,
        tcp_cap: float | None,
        window: float,
        on_button: Callable[[int], None],
        speed: float = 1.0,
    ) -> None:
        """`speeds` (full deflection) and `tcp_cap` at 100 %; `speed` the fraction asked."""
        super().__init__(press)
        self.controller = controller
        self.kinematics = kinematics
        self.feed = feed
        self.cartesian = cartesian
        self.frame = frame
        self.joints = joints
        self.speeds = speeds
        self.tcp_cap = tcp_cap
        self.speed = speed
        self.window = window
        self.on_button = on_button
        self.previous: FloatArray | None = None
        self.last_report: tuple[int, float] | None = None  # (seqno, when it arrived here)
        self.buttons: set[int] = set()
        self.idle = False
        self.course: pin.SE3 | None = None  # where the deflection so far should have led
        self.last_tick: float | None = None
        self.tick_dt = 0.0
        self.level = np.zeros(6)  # the deflection as followed: it changes in RAMP at most
        self.away = False  # the mouse is gone; the robot was halted
        self.after_halt = False  # the driver is halted: a new deflection needs its mode again
        # Checks a new deflection after a halt must pass as a new press would (control held).
        self.recheck: Callable[[], Awaitable[None]] | None = None
        self.armed = False  # its cap was seen at rest since it was bound or came back
        self.waits_for_rest = False  # deflected, but not armed: it drives nothing

    def follow(self, axes: FloatArray, dt: float) -> FloatArray:
        """The deflection, changing from rest to full (or back) in RAMP at the quickest: a
        cap let go at full speed then stops along the path it was moving on, not with every
        joint braking on its own."""
        most = dt / RAMP
        self.level = self.level + np.clip(axes - self.level, -most, most)
        return self.level

    def dt(self, now: float) -> float:
        """Seconds since the last tick (none before the first, at most 50 ms)."""
        self.tick_dt = 0.0 if self.last_tick is None else min(now - self.last_tick, 0.05)
        self.last_tick = now
        return self.tick_dt

    def keep_course(self, current: pin.SE3, twist: FloatArray) -> FloatArray:
        """The twist, plus a pull back onto the course it commands: the QP gives the nearest
        joint velocities, which near limits or a singularity are a little off, and a mouse
        held for seconds would add that up to centimetres. Only drift across the motion is
        corrected (nothing pulls along it, so letting go stops at once), and at most by
        MOUSE_LAG, so a robot held back is not pushed harder."""
        dt = self.tick_dt
        linear, angular = twist[:3], twist[3:]
        if self.course is None or not np.any(twist):
            self.course = current.copy()
            return twist
        position = self.course.translation + linear * dt - current.translation
        rotation = pin.log3(pin.exp3(angular * dt) @ self.course.rotation @ current.rotation.T)
        for error, direction, most in (
            (position, linear, MOUSE_LAG),
            (rotation, angular, MOUSE_LAG_ANGLE),
        ):
            norm = float(np.linalg.norm(direction))
            if norm > 1e-12:
                error -= direction * float(direction @ error) / norm**2
            size = float(np.linalg.norm(error))
            if size > most:
                error *= most / size
        self.course = pin.SE3(pin.exp3(rotation) @ current.rotation, current.translation + position)
        return twist + CORRECTION_GAIN * np.concatenate((position, rotation))

    def _halt(self, reason: str) -> Halt:
        self.done = True
        self.outcome = ("halted", reason)
        return Halt(f"{self.press}:halt")

    def _gone(self) -> Halt | None:
        """The mouse went away: the robot is halted once, and everything followed so far is
        forgotten (it comes back to a robot at rest)."""
        if self.away:
            return None
        self.away, self.armed, self.waits_for_rest = True, False, False
        self.previous, self.course, self.last_tick, self.last_report = None, None, None, None
        self.level = np.zeros(6)
        self.idle = True  # halted: nothing to hold until it is moved again
        self.after_halt = True
        return Halt(f"{self.press}:halt")

    def held(self) -> tuple[str, str]:
        """Why the binding drives nothing now: a code and the words for people, or two ""."""
        if self.away:
            return "mouse_away", "the 3D mouse is disconnected: halted until it is back"
        if self.waits_for_rest:
            return "mouse_not_at_rest", "let go of the 3D mouse: it drives once it was at rest"
        return "", ""

    def tick(self, state: RobotState, now: float) -> Streamed | None:
        device = self.feed.state
        if device is None or not device.connected:
            return self._gone()
        self.away = False
        if self.last_report is None or device.seqno != self.last_report[0]:
            self.last_report = (device.seqno, now)
        axes = np.array(device.axes)
        deflected = bool(np.any(axes != 0.0))
        if deflected and now - self.last_report[1] > self.window:
            silent = round((now - self.last_report[1]) * 1000)
            return self._halt(f"the 3D mouse stopped reporting for {silent} ms while deflected")
        for button in sorted(set(device.buttons) - self.buttons):
            self.on_button(button)
        self.buttons = set(device.buttons)
        # Bound, or back, with the cap pushed (a hand on it, or stuck): it drives only once
        # it has been let go, never on from where it was.
        self.armed = self.armed or not deflected
        self.waits_for_rest = deflected and not self.armed
        if self.waits_for_rest:
            axes, deflected = np.zeros(6), False
        q = np.array(state.joint_position_command)
        if self.after_halt:
            if not deflected:
                return None  # its halt holds the robot (braking still, maybe) until pushed
            # Pushed anew: it starts from rest, whatever the halt is still braking.
            self.previous = np.zeros(q.size)
        previous = np.array(state.joint_velocity) if self.previous is None else self.previous
        axes = self.follow(axes, self.dt(now))
        fraction = override(self.speed, state)
        cap = scaled_cap(self.tcp_cap, fraction)
        speeds = self.speeds * fraction
        if self.cartesian:
            twist = axes * speeds
            current = self.kinematics.tcp(q)
            if self.frame == "tool":
                rotation = current.rotation
                twist = np.concatenate((rotation @ twist[:3], rotation @ twist[3:]))
            twist = self.keep_course(current, twist)
            step = self.controller.from_twist(q, twist, cap, previous)
        else:
            self.course = None
            wanted = np.zeros(q.size)
            for axis, joint in enumerate(self.joints):
                wanted[joint] = axes[axis] * speeds[axis]
            step = self.controller.from_joint_velocity(q, wanted, cap, previous)
        still = not np.any(np.abs(step.velocity) > 1e-6)
        if still and not deflected:
            if self.idle:
                return None  # at rest: the driver holds; nothing to stream
            self.idle = True
            step.velocity = np.zeros(q.size)
        else:
            self.idle = False
        self.previous = step.velocity
        return VelocityCommand(
            velocity=step.velocity.tolist(), timeout=COMMAND_TIMEOUT, tag=self.tag()
        )
