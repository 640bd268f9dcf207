"""The simulated controller: command handling and one control cycle, with no threads and no
I/O, so tests can step it deterministically. The driver runs it at 500 Hz."""

from __future__ import annotations

import itertools
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from openpendant.runtime.interfaces.limits import CheckedTrajectory, FloatArray
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    OperationalMode,
    RobotFlags,
    RobotInfo,
    RobotState,
    TrajectoryState,
    TrajectoryStatus,
)
from openpendant.runtime.kit.errors import InvalidValue, NotFound, RobotError
from openpendant.runtime.kit.words import words
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.reference import Limits, RunningTrajectory, TrajectoryReference
from openpendant.runtime.robotics.time_scaling import TimeScaling
from openpendant.runtime.robotics.tracker import JointTracker, TrackerError

CYCLE = 0.002
STREAM_MODES = (
    CommandMode.jog,
    CommandMode.velocity_command,
    CommandMode.position_command,
    CommandMode.freedrive,
)
LIMIT_SLACK = 1e-6
# A position stream is extrapolated for up to twice the spacing of its samples (one may be
# late), that spacing taken as at most this: slower streams are held between samples.
MAX_STREAM_PERIOD = 0.05  # s
# Samples of a stream received closer together than this arrived in a burst.
BURST = CYCLE / 2
# How fast the servo pulls a pushed arm back onto its setpoint once the hand lets go.
SERVO_TIME_CONSTANT = 0.05  # s


@dataclass
class StreamCommand:
    mode: CommandMode
    velocity: FloatArray
    position: FloatArray | None
    received: float
    deadline: float
    acceleration: FloatArray | None = None
    horizon: float = CYCLE  # s after its receipt it is extrapolated for, at most

    def reference(self, now: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Where a position stream will be at the end of this cycle, extrapolated from its
        latest sample (which is already a little old), for as long as the next sample is
        not overdue. Then the point reached is held: a late stream brakes the arm, it is
        not carried on past where its samples led."""
        assert self.position is not None
        a = np.zeros_like(self.velocity) if self.acceleration is None else self.acceleration
        h = now - self.received + CYCLE
        if h > self.horizon:
            h = self.horizon
            held = self.position + self.velocity * h + 0.5 * a * h * h
            return held, np.zeros_like(held), np.zeros_like(held)
        return self.position + self.velocity * h + 0.5 * a * h * h, self.velocity + a * h, a


@dataclass(frozen=True)
class Setpoint:
    seqno: int
    t: float
    position: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    wall: float  # s since the epoch: lines up the setpoints of several robots


class SimCore:
    def __init__(self, info: RobotInfo, kinematics: Kinematics, history: int = 5000) -> None:
        self.info = info
        self.kinematics = kinematics
        self.tracker = JointTracker(info.joints, CYCLE, np.array(info.home))
        self.mode = CommandMode.halt
        self.operational_mode = OperationalMode.manual_reduced_speed
        self.enabled = False
        self.estop = False
        self.error = False
        self.error_message = ""
        self.protective = False  # the error is a protective stop
        self.speed_ratio = 1.0
        self.seqno = 0
        self.sim_time = 0.0
        self.cycle_time = time.time()  # wall-clock time of the latest cycle
        self.command: StreamCommand | None = None
        self.trajectory: RunningTrajectory | None = None
        self.scaling = TimeScaling(self.tracker.max_acceleration, self.tracker.max_jerk)
        self.limits = Limits.of(info.joints)
        self._finished: dict[str, TrajectoryStatus] = {}
        self._ids = itertools.count(1)
        self.command_timeouts = 0
        self.setpoints: deque[Setpoint] = deque(maxlen=history)
        self.tool_open: bool | None = True if "tool" in info.capabilities else None
        self.digital_inputs = [False] * info.digital_inputs
        self.digital_outputs = [False] * info.digital_outputs
        self.hand = np.zeros(len(info.joints))  # a hand on the arm (simulation only)
        # Where a hand pushing a servoed arm has put it, away from its setpoint.
        self.displacement = np.zeros(len(info.joints))

    # Commands -------------------------------------------------------------------------------

    @property
    def ready(self) -> bool:
        return self.enabled and not self.estop and not self.error

    def enable(self) -> None:
        if self.estop:
            raise RobotError(
                "the E-stop is engaged; release it first", code="estop", words=words("robot.estop")
            )
        if self.error:
            raise RobotError(
                "the robot has an error; reset errors first",
                code="robot_fault",
                words=words("robot.reset_first"),
            )
        self.enabled = True

    def disable(self) -> None:
        self.enabled = False
        self.halt("disabled")

    def reset_errors(self) -> None:
        if self.estop:
            raise RobotError("release the E-stop before resetting errors", code="estop")
        self.error = False
        self.error_message = ""
        self.protective = False

    def halt(self, reason: str = "halted") -> None:
        self.command = None
        self._end_trajectory(TrajectoryState.aborted, reason)
        self.mode = CommandMode.halt

    def set_mode(self, mode: CommandMode) -> None:
        if mode is not CommandMode.halt and not self.ready:
            raise RobotError(
                "the robot is not ready for motion",
                code="not_enabled",
                words=words("robot.not_enabled"),
            )
        if mode is not self.mode:
            # Passing through halt: whatever the old mode was doing stops here.
            self.halt(f"mode changed to {mode.value}")
            self.mode = mode

    def set_speed_ratio(self, ratio: float) -> None:
        self.speed_ratio = ratio

    def set_operational_mode(self, mode: OperationalMode) -> None:
        if mode is not self.operational_mode:
            self.halt("operational mode changed")
            self.operational_mode = mode

    def set_estop(self, engaged: bool) -> None:
        if engaged:
            self.estop = True
            self.enabled = False
            self.halt("E-stop")
        else:
            self.estop = False

    def push(self, velocity: FloatArray) -> None:
        """Simulation only: a hand pushing the arm at these joint velocities (zero: let go).
        Held free (freedrive), the arm goes where the hand takes it, within its limits.
        While the servos drive it (enabled, not halted), the hand pushes it off its
        setpoint, and they pull it back once it lets go. Halted, the brakes hold it."""
        v = np.asarray(velocity, dtype=float)
        if v.shape != self.hand.shape or not np.all(np.isfinite(v)):
            raise InvalidValue(f"a push needs {len(self.hand)} finite joint velocities")
        self.hand = np.clip(v, -self.tracker.max_velocity, self.tracker.max_velocity)

    def place(self, position: FloatArray) -> None:
        """Simulation only: the arm is at `position`, at rest, at once, as a test's set-up
        puts it there. Only while it stands still, and within its limits."""
        q = np.asarray(position, dtype=float)
        if q.shape != self.tracker.position.shape or not np.all(np.isfinite(q)):
            raise InvalidValue(f"a position needs {len(self.tracker.position)} finite values")
        if np.any(q < self.tracker.lower) or np.any(q > self.tracker.upper):
            raise RobotError("that position is outside the joint limits", code="joint_limit")
        if self.tracker.moving or self.trajectory is not None:
            raise RobotError("the robot is moving; stop it first", code="moving")
        self.halt("placed")
        self.tracker.place(q)
        self.displacement = np.zeros_like(self.displacement)

    def protective_stop(self, reason: str) -> None:
        """A safety stop, held until errors are reset (the runtime's path monitor)."""
        self.fault(f"protective stop: {reason}")
        self.protective = True

    def fault(self, message: str) -> None:
        self.error = True
        self.error_message = message
        self.command = None
        self._end_trajectory(TrajectoryState.failed, message)
        self.mode = CommandMode.halt

    def stream(
        self,
        mode: CommandMode,
        velocity: FloatArray | None,
        position: FloatArray | None,
        timeout: float,
        now: float,
    ) -> None:
        """Latest sample of a jog, velocity or position stream; it lapses after `timeout`."""
        self._require(mode)
        previous = self.command
        acceleration = None
        horizon = CYCLE
        if position is not None and previous is not None and previous.position is not None:
            dt = now - previous.received
            if BURST <= dt <= 2 * timeout:
                if velocity is None:
                    velocity = (position - previous.position) / dt
                acceleration = (velocity - previous.velocity) / dt
                horizon = 2 * min(dt, MAX_STREAM_PERIOD)
            elif 0 <= dt < BURST:
                # Held up on the way and arrived together (a stalled sender or link): their
                # spacing says nothing of the stream's, and a difference over it would be a
                # huge acceleration, extrapolated far past where the stream was heading.
                horizon = previous.horizon
                if velocity is None:
                    velocity = previous.velocity
        if velocity is None:
            if position is None:
                raise RobotError("a stream command needs a velocity or a position")
            velocity = np.zeros_like(position)
        self.command = StreamCommand(
            mode, velocity, position, now, now + timeout, acceleration, horizon
        )

    def prepare(self, trajectory: CheckedTrajectory) -> TrajectoryReference:
        """The reference the trajectory is followed by: as it is, or slowed along its path
        where it would pass a joint's limits. CPU work on a long one: off the control loop."""
        return TrajectoryReference.of(trajectory).within(self.limits)

    def start_trajectory(
        self, trajectory: CheckedTrajectory, reference: TrajectoryReference | None = None
    ) -> str:
        """Run `trajectory` (its reference already prepared, or prepared here)."""
        self._require(CommandMode.trajectory)
        if self.trajectory is not None:
            raise RobotError("a trajectory is already running", code="busy")
        trajectory_id = f"traj-{next(self._ids)}"
        if reference is None:
            reference = self.prepare(trajectory)
        self.trajectory = RunningTrajectory(trajectory_id, reference)
        self.scaling.rate, self.scaling.rate_speed = self.speed_ratio, 0.0  # it starts at rest
        return trajectory_id

    def pause_trajectory(self, paused: bool) -> TrajectoryStatus:
        running = self.trajectory
        if running is None:
            raise RobotError("no trajectory is running", code="not_running")
        running.state = TrajectoryState.paused if paused else TrajectoryState.running
        return running.status()

    def trajectory_status(self, trajectory_id: str) -> TrajectoryStatus:
        if self.trajectory is not None and self.trajectory.id == trajectory_id:
            return self.trajectory.status()
        if trajectory_id in self._finished:
            return self._finished[trajectory_id]
        raise NotFound(f"no trajectory {trajectory_id!r}")

    def _require(self, mode: CommandMode) -> None:
        if not self.ready:
            raise RobotError(
                "the robot is not ready for motion",
                code="not_enabled",
                words=words("robot.not_enabled"),
            )
        if self.mode is not mode:
            raise RobotError(
                f"the robot is in {self.mode.value} mode",
                code="wrong_mode",
                words=words("robot.wrong_mode", needed=mode.value, mode=self.mode.value),
            )

    def _end_trajectory(self, state: TrajectoryState, message: str = "") -> None:
        if self.trajectory is None:
            return
        self.trajectory.state = state
        self.trajectory.message = message
        self._finished[self.trajectory.id] = self.trajectory.status()
        while len(self._finished) > 32:
            self._finished.pop(next(iter(self._finished)))
        self.trajectory = None

    # One control cycle ----------------------------------------------------------------------

    def step(self, now: float) -> None:
        self.seqno += 1
        self.sim_time += CYCLE
        self.cycle_time = time.time()
        command = self.command
        if command is not None and now > command.deadline:
            self.command = None
            self.command_timeouts += 1
            command = None
        try:
            self._advance(command, now)
        except TrackerError as exc:
            self.fault(str(exc))
            self.tracker.hold()
        self._check_limits()
        self._push_off_setpoint()
        t = self.tracker
        self.setpoints.append(
            Setpoint(
                self.seqno, self.sim_time, t.position, t.velocity, t.acceleration, self.cycle_time
            )
        )

    def _advance(self, command: StreamCommand | None, now: float) -> None:
        tracker = self.tracker
        if not self.ready or self.mode is CommandMode.halt:
            tracker.hold()
        elif self.mode is CommandMode.trajectory:
            self._advance_trajectory()
        elif command is None or command.mode is not self.mode:
            tracker.hold()
        elif self.mode is CommandMode.freedrive:
            tracker.step_velocity(self.hand)  # free: the arm goes where the hand takes it
        elif command.position is not None:
            tracker.step_position(*command.reference(now))
        else:
            scale = self.speed_ratio if self.mode is CommandMode.jog else 1.0
            tracker.step_velocity(command.velocity * scale)

    def _advance_trajectory(self) -> None:
        running = self.trajectory
        if running is None:
            self.tracker.hold()
            return
        # The trajectory's clock runs at the speed override, or comes to a stop when paused:
        # the reference slows along its path, and the setpoints with it.
        self.tracker.follow(*running.advance(self.scaling, self.speed_ratio, CYCLE))
        if running.at_end and self.tracker.settled(running.reference.end):
            self._end_trajectory(TrajectoryState.finished)

    def _push_off_setpoint(self) -> None:
        if not self.displacement.any() and not self.hand.any():
            return
        servoed = self.ready and self.mode not in (CommandMode.halt, CommandMode.freedrive)
        if servoed and self.hand.any():
            moved = self.tracker.position + self.displacement + self.hand * CYCLE
            within = np.clip(moved, self.tracker.lower, self.tracker.upper)
            self.displacement = within - self.tracker.position
        elif servoed:  # let go: the servos pull the arm back onto its setpoint
            self.displacement *= np.exp(-CYCLE / SERVO_TIME_CONSTANT)
            self.displacement[np.abs(self.displacement) < 1e-9] = 0.0
        elif self.displacement.any() and not self.tracker.moving:
            # Halted: the brakes hold the arm where it was pushed, and that is where the
            # controller holds it from now on.
            self.tracker.place(self.tracker.position + self.displacement)
            self.displacement = np.zeros_like(self.displacement)

    def _check_limits(self) -> None:
        q = self.tracker.position
        t = self.tracker
        beyond = (q < t.lower - LIMIT_SLACK) | (q > t.upper + LIMIT_SLACK)
        if not beyond.any():
            return
        outside = np.flatnonzero(beyond)
        if not self.error:
            name = self.info.joints[int(outside[0])].name
            self.protective_stop(f"joint {name} passed its position limit")

    # State ----------------------------------------------------------------------------------

    def flags(self) -> RobotFlags:
        return RobotFlags(
            enabled=self.enabled,
            ready=self.ready,
            error=self.error,
            estop=self.estop,
            protective_stop=self.protective,
            homed=True,
            trajectory_running=self.trajectory is not None,
        )

    def snapshot(self) -> Snapshot:
        """Copy what the state needs, cheaply, so the control lock is held only briefly."""
        t = self.tracker
        return Snapshot(
            seqno=self.seqno,
            ts=self.cycle_time,
            command_mode=self.mode,
            operational_mode=self.operational_mode,
            flags=self.flags(),
            position=t.position + self.displacement,
            command=t.position.copy(),
            velocity=t.velocity.copy(),
            speed_ratio=self.speed_ratio,
            error_message=self.error_message,
            trajectory=self.trajectory.status() if self.trajectory is not None else None,
            tool_open=self.tool_open,
            digital_inputs=tuple(self.digital_inputs),
            digital_outputs=tuple(self.digital_outputs),
        )

    def state(self) -> RobotState:
        return self.snapshot().to_state(self.kinematics)


@dataclass(frozen=True)
class Snapshot:
    seqno: int
    ts: float
    command_mode: CommandMode
    operational_mode: OperationalMode
    flags: RobotFlags
    position: FloatArray  # where the arm is
    command: FloatArray  # its setpoint
    velocity: FloatArray
    speed_ratio: float
    error_message: str
    trajectory: TrajectoryStatus | None
    tool_open: bool | None
    digital_inputs: tuple[bool, ...]
    digital_outputs: tuple[bool, ...]

    def to_state(self, kinematics: Kinematics) -> RobotState:
        return RobotState(
            seqno=self.seqno,
            ts=self.ts,
            command_mode=self.command_mode,
            operational_mode=self.operational_mode,
            flags=self.flags,
            joint_position=self.position.tolist(),
            joint_velocity=self.velocity.tolist(),
            joint_position_command=self.command.tolist(),
            tcp_pose=kinematics.tcp_pose(self.position),
            speed_ratio=self.speed_ratio,
            error_message=self.error_message,
            trajectory=self.trajectory,
            tool_open=self.tool_open,
            digital_inputs=list(self.digital_inputs),
            digital_outputs=list(self.digital_outputs),
        )
