"""Any Robot Raconteur standard robot as an OpenPendant robot. A control thread runs at the
robot's state rate: it reads the newest `robot_state` and sends the current mode's command.

- Jogging: RR's `jog_joint` (a velocity held for at most the command's timeout, by the robot
  too), sent at once on each new command; halted when OpenPendant's stream lapses.
- Trajectories: the planned, limit-checked trajectory streamed on the position command wire,
  sampled on its own clock at the speed override (the time scaling the other drivers use, so
  a pause is a controlled stop along the path); the runtime checked that exact path, which
  RR's own `execute_trajectory` would re-time.
- Position and velocity streams: the position and velocity command wires.
- An E-stop, an error or a lost link halts everything and is an error until reset: nothing
  resumes by itself. A state whose `seqno` stands still for `STALE_AFTER` is a lost link."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import itertools
import logging
import queue
import threading
import time
from collections.abc import Callable

import numpy as np

from openpendant.plugins.robotraconteur.node import Node
from openpendant.plugins.robotraconteur.robot_link import LINK_ERRORS, RR_MODES, Reading, RRLink
from openpendant.runtime.interfaces.device import DeviceIdentity
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
from openpendant.runtime.interfaces.robot_driver import RobotDriver, RobotStatus
from openpendant.runtime.kit.errors import NotFound, RobotError
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.reference import Limits, RunningTrajectory, TrajectoryReference
from openpendant.runtime.robotics.time_scaling import TimeScaling

log = logging.getLogger(__name__)
RECONNECT_AFTER = 1.0  # s between attempts
STALE_AFTER = 0.25  # s without a new state: the link is lost (RR's own robots allow as much)
LATE_TICK = 0.03  # s of a trajectory's clock one cycle may advance, however late it runs
AT_END = 1e-3  # rad from a trajectory's end at which it has arrived
ESTOP = "E-stop: release it, then reset errors and enable"
ROBOT_ERROR = "the robot reports an error: reset errors to go on"
FATAL_ERROR = "the robot reports a fatal error: restart it, then reset errors"
STOP_TIMEOUT = 0.05  # s: how long a lapsed jog's stop (a zero velocity) is held
ENABLED_WITHIN = 2.0  # s for the robot to say it is enabled once asked
MODE_WITHIN = 1.0  # s for the robot's states to show a mode this driver set
Stream = tuple[CommandMode, FloatArray | None, FloatArray | None, float]


class LinkStale(RobotError):
    """The robot's state stopped coming."""


class RRRobotDriver(RobotDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        info: RobotInfo,
        url: str,
        *,
        node: Node,
        link: RRLink | None = None,
        user: str | None = None,
        password: str | None = None,
        period: float = 0.01,
    ) -> None:
        super().__init__(identity, info)
        self.url, self.node, self.user, self.password = url, node, user, password
        self.period = period
        self.kinematics = Kinematics(info)
        self.lock = threading.RLock()
        self.link = link
        self.reading: Reading | None = link.read() if link is not None else None
        self.enabled = False
        self._enabled_seen = False  # the robot has said it is enabled since we enabled it
        self.error = link is None
        self.error_message = "" if link is not None else "not connected yet"
        self._ever_connected = link is not None
        self.mode = CommandMode.halt
        self.speed_ratio = 1.0
        self.stream: Stream | None = None
        self._sent_stream: Stream | None = None
        self._sent_ratio = 1.0  # the speed ratio of the jog sent last
        self.trajectory: RunningTrajectory | None = None
        self._streamed_at: float | None = None
        self._finished: dict[str, TrajectoryStatus] = {}
        self._ids = itertools.count(1)
        self.motion_limits = Limits.of(info.joints)
        self.scaling = TimeScaling(self.motion_limits.acceleration, self.motion_limits.jerk)
        self.seqno = 0
        # The RR command mode this driver last set. Taken as halt on connecting: the robot's
        # mode is left alone (another RR client may be driving it) until this driver is
        # enabled and commands it.
        self._rr_mode = CommandMode.halt
        self._mode_set_at = 0.0  # monotonic, when this driver last set the robot's mode
        self._mode_shown = True  # a state has shown that mode since
        self._running = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._requests: queue.Queue[
            tuple[Callable[[RRLink], None], concurrent.futures.Future[None]]
        ] = queue.Queue()

    # The control thread -------------------------------------------------------------------

    async def start(self) -> None:
        self._running.set()
        self._thread = threading.Thread(target=self._loop, name="rr-control", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        await self.halt()
        with contextlib.suppress(Exception):  # the robot gone, or not answering
            await asyncio.wait_for(
                self._in_control_thread(lambda link: link.set_mode(CommandMode.halt)), 3.0
            )
        self._running.clear()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 3.0)
        with self.lock:
            link, self.link = self.link, None
        if link is not None:
            link.close()
        self.node.close()

    def _loop(self) -> None:
        next_at = time.monotonic()
        last_attempt = time.monotonic() if self.link is not None else -RECONNECT_AFTER
        while self._running.is_set():
            if self.link is None and time.monotonic() - last_attempt >= RECONNECT_AFTER:
                last_attempt = time.monotonic()
                self._try_connect()
            link = self.link
            if link is not None:
                try:
                    self._serve_requests(link)
                    self._cycle(link)
                except (*LINK_ERRORS, LinkStale) as exc:
                    self._lost(f"the connection to the robot failed: {exc}")
                except Exception as exc:
                    self._refused(link, exc)
            next_at += self.period
            delay = next_at - time.monotonic()
            if delay < -self.period:
                next_at, delay = time.monotonic(), 0.0
            if self._wake.wait(max(delay, 0.0)):
                self._wake.clear()
                next_at = time.monotonic()

    def _serve_requests(self, link: RRLink) -> None:
        while not self._requests.empty():
            work, done = self._requests.get_nowait()
            try:
                work(link)
            except Exception as exc:
                done.set_exception(RobotError(f"the robot refused: {exc}", code="robot_refused"))
            else:
                done.set_result(None)

    def _try_connect(self) -> None:
        try:
            link = RRLink(self.node, self.url, self.user, self.password)
        except Exception as exc:
            with self.lock:
                self.error, self.error_message = (
                    True,
                    f"cannot reach the robot at {self.url}: {exc}",
                )
            return
        with self.lock:
            self.link, self.reading, self._rr_mode = link, link.read(), CommandMode.halt
            if self._ever_connected:
                self.error = True
                self.error_message = "the connection was lost and is back: reset errors to go on"
            else:
                self.error, self.error_message = False, ""
            self._ever_connected = True
        log.info("connected to %s", self.url)

    def _refused(self, link: RRLink, exc: Exception) -> None:
        """A command the robot would not take: most often because it has just stopped (its
        E-stop, its error), which is then what the fault says."""
        log.warning("the robot refused a command: %s", exc)
        try:
            reading = link.read()
        except Exception:
            reading = None
        with self.lock:
            if reading is not None and link.estop(reading):
                self._fault(ESTOP)
            elif reading is not None and link.has(reading, "fatal_error"):
                self._fault(FATAL_ERROR)
            elif reading is not None and link.has(reading, "error"):
                self._fault(ROBOT_ERROR)
            else:
                self._fault(f"the robot refused a command: {exc}")

    def _lost(self, why: str) -> None:
        log.warning("%s", why)
        with self.lock:
            link, self.link = self.link, None
            self._fault(why)
        if link is not None:
            link.close()
        while not self._requests.empty():
            _, done = self._requests.get_nowait()
            done.set_exception(RobotError(why, code="disconnected"))

    def _fault(self, message: str) -> None:
        """Halted, and an error until reset: never resumed by itself."""
        self.error, self.error_message = True, message
        self.enabled = False
        self._end(TrajectoryState.failed, message)
        self.stream = None
        self.mode = CommandMode.halt

    def _cycle(self, link: RRLink) -> None:
        reading = link.read()
        if time.monotonic() - reading.received > STALE_AFTER:
            raise LinkStale(f"no new state for {STALE_AFTER * 1000:.0f} ms")
        with self.lock:
            self.seqno += 1
            if link.estop(reading):
                # Also over a fault the robot's stop caused first (a command it then refused).
                if not self.error or self.error_message != ESTOP:
                    self._fault(ESTOP)
            elif link.has(reading, "communication_failure") and not self.error:
                self._fault("the robot lost its own controller (communication failure)")
            elif link.has(reading, "fatal_error"):
                if not self.error or self.error_message != FATAL_ERROR:
                    self._fault(FATAL_ERROR)
            elif link.has(reading, "error") and not self.error:
                self._fault(ROBOT_ERROR)
            elif not link.has(reading, "enabled"):
                if self.enabled and self._enabled_seen and not self.error:
                    self._fault("the robot was disabled on its own side")
            elif self.enabled and not self._enabled_seen:
                # Enabled once the robot says it is enabled and ready (it may take a state or
                # two after being asked).
                self._enabled_seen = link.has(reading, "ready")
            elif self.enabled and not self.error and not link.has(reading, "ready"):
                # Its drives, its controller: whatever it was doing stays stopped.
                self._fault("the robot is no longer ready (it stopped on its own side)")
            elif (left := self._left_mode(link, reading)) and not self.error:
                self._fault(left)
            previous = self.reading
            if previous is not None and previous.operational_mode is not reading.operational_mode:
                log.info("operational mode: %s", reading.operational_mode.value)
                if self.mode is not CommandMode.halt:
                    self._halt_now(f"operational mode changed to {reading.operational_mode.value}")
            self.reading = reading
            mode = self.mode if self._ready(link, reading) else CommandMode.halt
            stream, trajectory = self.stream, self.trajectory
        if mode is not self._rr_mode:
            link.set_mode(mode, through_halt=self._rr_mode is not CommandMode.halt)
            with self.lock:
                self._rr_mode, self._mode_set_at = mode, time.monotonic()
                self._mode_shown = False
            self._sent_stream = None
        if mode is CommandMode.trajectory and trajectory is not None:
            self._advance(link, trajectory, reading)
        elif mode in (CommandMode.jog, CommandMode.position_command, CommandMode.velocity_command):
            self._stream(link, mode, stream)

    def _stream(self, link: RRLink, mode: CommandMode, stream: Stream | None) -> None:
        if stream is None or stream[0] is not mode or time.monotonic() > stream[3]:
            with self.lock:
                if self.stream is stream:
                    self.stream = None
            if self._sent_stream is not None:
                # The stream lapsed: stop now, once, in the same mode (RR's own timeout on a
                # jog would stop it too; a position stream holds where it was sent last).
                zero = np.zeros(self.info.dof)
                if mode is CommandMode.jog:
                    link.jog(zero, STOP_TIMEOUT)
                elif mode is CommandMode.velocity_command:
                    link.velocity(zero)
                self._sent_stream = None
            return
        with self.lock:
            if self.stream is not stream or self.mode is not mode:
                return  # halted or replaced since this cycle read it
        _, velocity, position, deadline = stream
        if mode is CommandMode.jog:
            ratio = self.speed_ratio
            changed = stream is not self._sent_stream or ratio != self._sent_ratio
            if velocity is not None and changed:
                # RR's jog holds the velocity for the command's own time, no longer; sent
                # again when the speed override changes while it is held.
                link.jog(velocity * ratio, max(deadline - time.monotonic(), 0.01))
                self._sent_ratio = ratio
        elif position is not None:
            link.position(position)
        elif velocity is not None:
            link.velocity(velocity)
        self._sent_stream = stream

    def _advance(self, link: RRLink, running: RunningTrajectory, reading: Reading) -> None:
        now = time.monotonic()
        with self.lock:
            if self.trajectory is not running or self.mode is not CommandMode.trajectory:
                return  # halted or replaced since this cycle read it
            if self._streamed_at is None:
                position = running.reference.sample(0.0)[0]
            else:
                step = min(now - self._streamed_at, LATE_TICK)
                position, _, _ = running.advance(self.scaling, self.speed_ratio, step)
            self._streamed_at = now
        link.position(position)
        if running.at_end and np.abs(np.array(reading.q) - running.reference.end).max() < AT_END:
            with self.lock:
                self._end(TrajectoryState.finished)

    def _left_mode(self, link: RRLink, reading: Reading) -> str:
        """Why the robot is not in the mode this driver put it in, or "". States sent before
        it took the mode may arrive after the call that set it: only once a state has shown
        the mode does a state without it mean the robot left it."""
        if self._rr_mode is CommandMode.halt:
            return ""
        if reading.command_mode == link.modes[RR_MODES[self._rr_mode]]:
            self._mode_shown = True
            return ""
        if self._mode_shown:
            return "the robot left the command mode it was put in (another client?)"
        if time.monotonic() - self._mode_set_at > MODE_WITHIN:
            return f"the robot did not show the command mode it was put in within {MODE_WITHIN:g} s"
        return ""

    def _ready(self, link: RRLink, reading: Reading) -> bool:
        return (
            self.enabled
            and self._enabled_seen
            and not self.error
            and link.has(reading, "enabled")
            and link.has(reading, "ready")
            and not link.estop(reading)
            and not link.has(reading, "fatal_error")
        )

    def _end(self, state: TrajectoryState, message: str = "") -> None:
        running = self.trajectory
        if running is None:
            return
        running.state, running.message = state, message
        self._finished[running.id] = running.status()
        while len(self._finished) > 32:
            self._finished.pop(next(iter(self._finished)))
        self.trajectory = None
        self._streamed_at = None

    # State ----------------------------------------------------------------------------------

    def _flags(self) -> RobotFlags:
        reading, link = self.reading, self.link
        connected = link is not None and reading is not None
        return RobotFlags(
            enabled=self.enabled and self._enabled_seen,
            ready=bool(connected and link and reading and self._ready(link, reading)),
            error=self.error,
            estop=bool(link and reading and link.estop(reading)),
            homed=True,
            communication_failure=not connected,
            trajectory_running=self.trajectory is not None,
        )

    def state(self) -> RobotState:
        with self.lock:
            reading = self.reading
            q = reading.q if reading else list(self.info.home)
            qd = reading.qd if reading else [0.0] * len(q)
            # A new state at every publication, with or without the robot (as the UR's): a
            # number that stood still would make the runtime's link stale over and over.
            self.seqno += 0 if self.link is not None else 1
            return RobotState(
                seqno=self.seqno,
                ts=time.time(),
                command_mode=self.mode,
                operational_mode=(
                    reading.operational_mode if reading else OperationalMode.undefined
                ),
                flags=self._flags(),
                joint_position=q,
                joint_velocity=qd,
                joint_position_command=q,
                tcp_pose=self.kinematics.tcp_pose(np.array(q)),
                speed_ratio=self.speed_ratio,
                error_message=self.error_message if self.error else "",
                trajectory=self.trajectory.status() if self.trajectory else None,
            )

    def status(self) -> RobotStatus:
        with self.lock:
            q = self.reading.q if self.reading else list(self.info.home)
            return RobotStatus(self._flags(), self.mode, self.error_message, q)

    async def trajectory_status(self, trajectory_id: str) -> TrajectoryStatus:
        with self.lock:
            if self.trajectory is not None and self.trajectory.id == trajectory_id:
                return self.trajectory.status()
            if trajectory_id in self._finished:
                return self._finished[trajectory_id]
        raise NotFound(f"no trajectory {trajectory_id!r}")

    # Hooks ----------------------------------------------------------------------------------

    async def _in_control_thread(self, work: Callable[[RRLink], None]) -> None:
        """RR's calls block: each goes through the control thread, between two cycles."""
        if self.link is None:
            raise RobotError(f"not connected to the robot at {self.url}", code="disconnected")
        done: concurrent.futures.Future[None] = concurrent.futures.Future()
        self._requests.put((work, done))
        self._wake.set()
        await asyncio.wrap_future(done)

    async def _enable(self) -> None:
        def enable(link: RRLink) -> None:
            with self.lock:
                self._halt_now("enabling")
            link.enable()
            self._rr_mode = CommandMode.halt
            with self.lock:
                self.enabled, self._enabled_seen = True, False

        await self._in_control_thread(enable)
        # Done once the robot says so (its next state), or refused.
        deadline = time.monotonic() + ENABLED_WITHIN
        while not self._enabled_seen:
            with self.lock:
                if not self.enabled:
                    raise RobotError(f"the robot did not enable: {self.error_message}")
            if time.monotonic() > deadline:
                with self.lock:
                    self.enabled = False
                    self._halt_now("the robot did not enable")
                raise RobotError(
                    f"the robot did not say it was enabled within {ENABLED_WITHIN:g} s",
                    code="not_enabled",
                )
            await asyncio.sleep(self.period / 2)

    async def _disable(self) -> None:
        with self.lock:
            self.enabled = False
            self._halt_now("disabled")
        await self._in_control_thread(RRLink.disable)

    async def _reset_errors(self) -> None:
        with self.lock:
            reading, link = self.reading, self.link
        if link is not None and reading is not None and link.estop(reading):
            raise RobotError("release the E-stop before resetting errors", code="estop")
        if link is not None and reading is not None and link.has(reading, "fatal_error"):
            raise RobotError(FATAL_ERROR, code="robot_error")

        def reset(link: RRLink) -> None:
            link.reset_errors()
            with self.lock:
                if self.link is link:  # not a link lost meanwhile
                    self.error, self.error_message = False, ""

        await self._in_control_thread(reset)

    def _halt_now(self, reason: str) -> None:
        self.stream = None
        self._end(TrajectoryState.aborted, reason)
        self.mode = CommandMode.halt
        self._wake.set()

    async def _halt(self) -> None:
        with self.lock:
            self._halt_now("halted")

    async def _protective_stop(self, reason: str) -> None:
        with self.lock:
            self._halt_now(reason)
            self._fault(f"protective stop: {reason}")

    async def _set_command_mode(self, mode: CommandMode) -> None:
        with self.lock:
            if mode is not self.mode:
                self._halt_now(f"mode changed to {mode.value}")
                self.mode = mode

    async def _set_speed_ratio(self, ratio: float) -> None:
        with self.lock:
            self.speed_ratio = ratio

    async def _jog_joint(self, velocity: FloatArray, timeout: float) -> None:
        with self.lock:
            self.stream = (CommandMode.jog, velocity, None, time.monotonic() + timeout)
        self._wake.set()

    async def _velocity_command(self, velocity: FloatArray, timeout: float) -> None:
        with self.lock:
            self.stream = (CommandMode.velocity_command, velocity, None, time.monotonic() + timeout)

    async def _position_command(
        self, position: FloatArray, velocity: FloatArray | None, timeout: float
    ) -> None:
        with self.lock:
            self.stream = (CommandMode.position_command, None, position, time.monotonic() + timeout)

    async def _execute_trajectory(self, trajectory: CheckedTrajectory) -> str:
        prepared_since = self.interruptions
        reference = await asyncio.to_thread(
            TrajectoryReference.of(trajectory).within, self.motion_limits
        )
        with self.lock:
            self._refuse_if_interrupted(prepared_since)
            if self.trajectory is not None:
                raise RobotError("a trajectory is already running", code="busy")
            trajectory_id = f"traj-{next(self._ids)}"
            self.trajectory = RunningTrajectory(trajectory_id, reference)
            self._streamed_at = None
            self.scaling.rate, self.scaling.rate_speed = self.speed_ratio, 0.0
            return trajectory_id

    async def _pause_trajectory(self, paused: bool) -> TrajectoryStatus:
        with self.lock:
            running = self.trajectory
            if running is None:
                raise RobotError("no trajectory is running", code="not_running")
            running.state = TrajectoryState.paused if paused else TrajectoryState.running
            return running.status()
