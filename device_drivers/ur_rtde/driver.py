"""A Universal Robots arm through ur-rtde. A control thread runs at the controller's pace
(8 ms): it reads the state, sends the current mode's command and feeds the RTDE watchdog,
so a runtime that dies stops the robot within the watchdog's period. One package per cycle:
the controller applies the registers once per 2 ms, so a kick sent right after a speedJ
would replace it before the script saw it.

- Jogging and velocity streams: speedJ, stopped (stopJ) when the stream's timeout lapses.
- Trajectories: servoJ streaming of the planned, limit-checked trajectory, sampled on its
  own clock at the speed override (the same time scaling as the simulated robot's, so a
  pause is a controlled stop along the path). servoJ rather than moveJ with blends: the
  runtime plans the timing and checks collisions along that exact path; moveJ would let the
  controller re-time and blend it.
- Position streams: servoJ.
- A lost connection, a protective stop or an E-stop halts everything and is an error until
  reset; nothing resumes by itself. The link is made again on its own."""

from __future__ import annotations

import asyncio
import concurrent.futures
import itertools
import logging
import queue
import threading
import time
from collections.abc import Callable

import numpy as np

from openpendant.device_drivers.ur_rtde.io_writer import OutputWriter
from openpendant.device_drivers.ur_rtde.link import RUNNING, Reading, URLink
from openpendant.device_drivers.ur_rtde.modes import ModeWatch
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.limits import CheckedTrajectory, FloatArray
from openpendant.runtime.interfaces.robot import (
    POWER_ON,
    UNLOCK_PROTECTIVE_STOP,
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
CYCLE = 0.008  # s: servoJ's time per command, and the control thread's period
RECONNECT_AFTER = 1.0  # s between attempts
# The controller's operational mode as the pendant's rules see it: jogging is for manual
# mode, at reduced speed (UR's manual mode with an enabling device caps the TCP at 250 mm/s
# too). A controller without mode selection is jogged as in manual mode.
OPERATIONAL_MODES = {
    "MANUAL": OperationalMode.manual_reduced_speed,
    "AUTOMATIC": OperationalMode.auto,
    "NONE": OperationalMode.manual_reduced_speed,
}
STOP_DECELERATION = 2.0  # rad/s² for stopJ
TOOL_OUTPUT_0 = 16  # the tool outputs' first bit in the controller's digital output bits
OUTPUT_SEEN_WITHIN = 1.0  # s for a written output to show in the controller's state


class URDriver(RobotDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        info: RobotInfo,
        host: str,
        *,
        frequency: float = -1.0,
        watchdog_hz: float = 10.0,
        lookahead: float = 0.1,
        gain: float = 300.0,
        connect: Callable[[str, float, str], URLink] = URLink,
    ) -> None:
        added = [c for c in (POWER_ON, UNLOCK_PROTECTIVE_STOP) if c not in info.capabilities]
        info = info.model_copy(update={"capabilities": [*info.capabilities, *added]})
        super().__init__(identity, info)
        self.host, self.frequency = host, frequency
        self.watchdog_hz, self.lookahead, self.gain = watchdog_hz, lookahead, gain
        self.connect = connect
        self.kinematics = Kinematics(info)
        self.lock = threading.RLock()
        self.link: URLink | None = None
        self.reading: Reading | None = None
        self.enabled = False
        self.error_message = "not connected yet"
        self.error = True
        self.mode = CommandMode.halt
        self.speed_ratio = 1.0
        self.stream: tuple[CommandMode, FloatArray | None, FloatArray | None, float] | None = None
        self.trajectory: RunningTrajectory | None = None
        self._streaming: RunningTrajectory | None = None  # the trajectory servoJ has begun
        self._finished: dict[str, TrajectoryStatus] = {}
        self._ids = itertools.count(1)
        self.motion_limits = Limits.of(info.joints)
        self.scaling = TimeScaling(self.motion_limits.acceleration, self.motion_limits.jerk)
        self.seqno = 0
        self._ever_connected = False
        self._moving = False  # a motion command went out since the last stop
        self._teaching = False  # the controller is in teach mode (freedrive)
        self.operational_mode = OperationalMode.manual_reduced_speed
        self._modes = ModeWatch(host, self._mode_seen, lambda: self.link is not None)
        self.writer = OutputWriter(host)
        self._running = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._requests: queue.Queue[
            tuple[Callable[[URLink], None], concurrent.futures.Future[None]]
        ] = queue.Queue()
        self.cycles = 0

    # The control thread -------------------------------------------------------------------

    async def start(self) -> None:
        self._modes.start()
        self._running.set()
        self._thread = threading.Thread(target=self._loop, name="ur-control", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        await self.halt()
        self._running.clear()
        self._modes.close()
        await self.writer.close()
        if self._thread is not None:
            self._thread.join(timeout=3.0)
        with self.lock:
            if self.link is not None:
                self.link.close()
                self.link = None

    def _loop(self) -> None:
        next_at = time.monotonic()
        last_attempt = -RECONNECT_AFTER
        while self._running.is_set():
            if self.link is None and time.monotonic() - last_attempt >= RECONNECT_AFTER:
                last_attempt = time.monotonic()
                self._try_connect()
            if self.link is not None:
                self._serve_requests(self.link)
            if self.link is not None:
                try:
                    self._cycle()
                except Exception as exc:
                    self._lost(f"the connection to the robot failed: {exc}")
            next_at += CYCLE
            delay = next_at - time.monotonic()
            if delay < -CYCLE:
                next_at, delay = time.monotonic(), 0.0
            # A new press or stream sample is sent at once, not at the next tick.
            if self._wake.wait(max(delay, 0.0)):
                self._wake.clear()
                next_at = time.monotonic()

    def _mode_seen(self, answer: str) -> None:
        """From the mode watch's thread."""
        mode = OPERATIONAL_MODES[answer]
        with self.lock:
            if mode is not self.operational_mode:
                log.info("operational mode: %s", mode.value)
                if self.mode is not CommandMode.halt:
                    self._halt_now(f"operational mode changed to {mode.value}")
                self.operational_mode = mode

    def _serve_requests(self, link: URLink) -> None:
        while not self._requests.empty():
            work, done = self._requests.get_nowait()
            try:
                work(link)
            except Exception as exc:
                done.set_exception(exc)
            else:
                done.set_result(None)

    def _try_connect(self) -> None:
        try:
            link = self.connect(self.host, self.frequency, self.info.model)
            link.control.setWatchdog(self.watchdog_hz)
        except Exception as exc:
            wrong = isinstance(exc, RobotError) and exc.code == "wrong_model"
            with self.lock:
                self.error, self.error_message = (
                    True,
                    str(exc) if wrong else f"cannot reach the robot at {self.host}: {exc}",
                )
            return
        with self.lock:
            self.link = link
            self.reading = link.read()
            if self._ever_connected:
                self.error_message = "the connection was lost and is back: reset errors to go on"
            else:
                self.error, self.error_message = False, ""
            self._ever_connected = True
            log.info("connected to %s", self.host)

    def _lost(self, why: str) -> None:
        log.warning("%s", why)
        with self.lock:
            link, self.link = self.link, None
            self._teaching = False  # the program (and its teach mode) ends with the link
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

    def _cycle(self) -> None:
        with self.lock:
            link = self.link
            assert link is not None
            if not link.connected:
                raise RobotError("the controller stopped answering")
            reading = self.reading = link.read()
            self.seqno += 1
            self.cycles += 1
            if reading.estop and not self.error:
                self._fault("E-stop: release it, then power on and reset errors")
            elif reading.protective_stop and not self.error:
                self._fault("protective stop: make the cell safe, then reset errors")
            elif self.enabled and not reading.program_running and not self.error:
                self._fault(
                    "the control program stopped on the robot (watchdog, or stopped on its pendant)"
                )
            self._command(link, reading)

    def _command(self, link: URLink, reading: Reading) -> None:
        control = link.control
        if not self._ready(reading) or self.mode is CommandMode.halt:
            self._stop(link)
            return
        if self.mode is CommandMode.trajectory:
            self._advance(link)
            return
        stream = self.stream
        if stream is None or stream[0] is not self.mode or time.monotonic() > stream[3]:
            self.stream = None
            self._stop(link)
            return
        _, velocity, position, _ = stream
        if self.mode is CommandMode.freedrive:
            if not self._teaching:
                control.teachMode()
                self._teaching = True
            else:
                control.kickWatchdog()
            return
        if position is not None:
            control.servoJ(position.tolist(), 0.0, 0.0, CYCLE, self.lookahead, self.gain)
        elif velocity is not None:
            scale = self.speed_ratio if self.mode is CommandMode.jog else 1.0
            control.speedJ((velocity * scale).tolist(), self._acceleration(), CYCLE)
        self._moving = True

    def _stop(self, link: URLink) -> None:
        if self._teaching:  # held free no longer: the arm holds where the hand left it
            link.control.endTeachMode()
            self._teaching = False
        if self._moving:
            link.control.stopJ(STOP_DECELERATION, True)
            self._moving = False
        else:
            link.control.kickWatchdog()

    def _acceleration(self) -> float:
        return float(min(j.max_acceleration for j in self.info.joints))

    def _advance(self, link: URLink) -> None:
        running = self.trajectory
        if running is None:
            self._stop(link)
            return
        if running is self._streaming:
            position, _, _ = running.advance(self.scaling, self.speed_ratio, CYCLE)
        else:
            # The first target is where the trajectory begins, at rest: the controller's
            # interpolation through the targets then begins with it, as the plan does.
            self._streaming = running
            position = running.reference.sample(0.0)[0]
        link.control.servoJ(position.tolist(), 0.0, 0.0, CYCLE, self.lookahead, self.gain)
        self._moving = True
        reading = self.reading
        if (
            running.at_end
            and reading is not None
            and np.abs(np.array(reading.q) - running.reference.end).max() < 1e-4
        ):
            self._end(TrajectoryState.finished)
            self._stop(link)

    def _ready(self, reading: Reading) -> bool:
        return (
            self.enabled
            and not self.error
            and reading.robot_mode == RUNNING
            and reading.program_running
            and not reading.estop
            and not reading.protective_stop
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

    # State ----------------------------------------------------------------------------------

    def _flags(self) -> RobotFlags:
        reading = self.reading
        connected = self.link is not None and reading is not None
        return RobotFlags(
            enabled=self.enabled,
            ready=connected and reading is not None and self._ready(reading),
            error=self.error,
            estop=bool(reading and reading.estop),
            protective_stop=bool(reading and reading.protective_stop),
            reduced_speed=bool(reading and reading.reduced),
            homed=True,
            communication_failure=not connected,
            trajectory_running=self.trajectory is not None,
        )

    def _published_seqno(self) -> int:
        """The number of the state published now (under the lock). Each control cycle is a
        new state; without a controller there are no cycles, but what the driver then says
        (an error: no controller) is news at every publication. A number that stood still
        made the runtime's link stale, end and connect again every few tenths of a second
        for as long as the controller was gone; and a controller that does not answer can
        hold the control thread in a connection attempt for seconds."""
        if self.link is None:
            self.seqno += 1
        return self.seqno

    def state(self) -> RobotState:
        with self.lock:
            reading = self.reading
            q = reading.q if reading else list(self.info.home)
            qd = reading.qd if reading else [0.0] * len(q)
            n_in, n_out = self.info.digital_inputs, self.info.digital_outputs
            return RobotState(
                seqno=self._published_seqno(),
                ts=time.time(),
                command_mode=self.mode,
                operational_mode=self.operational_mode,
                flags=self._flags(),
                joint_position=q,
                joint_velocity=qd,
                joint_position_command=q,
                tcp_pose=self.kinematics.tcp_pose(np.array(q)),
                speed_ratio=self.speed_ratio,
                error_message=self.error_message if self.error else "",
                trajectory=self.trajectory.status() if self.trajectory else None,
                tool_open=None
                if reading is None
                else not bool(reading.digital_outputs >> TOOL_OUTPUT_0 & 1),
                digital_inputs=[
                    bool(reading and reading.digital_inputs >> i & 1) for i in range(n_in)
                ],
                digital_outputs=[
                    bool(reading and reading.digital_outputs >> i & 1) for i in range(n_out)
                ],
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

    def _link(self) -> URLink:
        if self.link is None:
            raise RobotError(f"not connected to the robot at {self.host}", code="disconnected")
        return self.link

    async def _in_control_thread(self, work: Callable[[URLink], None]) -> None:
        """ur-rtde's control interface takes one command at a time: every call that is not
        the cycle's own goes through the control thread, between two cycles."""
        self._link()
        done: concurrent.futures.Future[None] = concurrent.futures.Future()
        self._requests.put((work, done))
        await asyncio.wrap_future(done)

    async def _enable(self) -> None:
        def power_and_script(link: URLink) -> None:
            link.power_up()
            link.run_script()
            link.control.setWatchdog(self.watchdog_hz)
            with self.lock:
                self.enabled = True

        await self._in_control_thread(power_and_script)

    async def _disable(self) -> None:
        with self.lock:
            self.enabled = False
            self._halt_now("disabled")

    async def _reset_errors(self) -> None:
        with self.lock:
            reading = self.reading
            self._link()
        if reading is not None and reading.estop:
            raise RobotError("release the E-stop before resetting errors", code="estop")
        if reading is not None and reading.protective_stop:
            await self._in_control_thread(URLink.unlock)
        with self.lock:
            self.error, self.error_message = False, ""

    def _halt_now(self, reason: str) -> None:
        self.stream = None
        self._end(TrajectoryState.aborted, reason)
        self.mode = CommandMode.halt

    async def _halt(self) -> None:
        with self.lock:
            self._halt_now("halted")

    async def _protective_stop(self, reason: str) -> None:
        """The runtime's stop (its path monitor): held as an error until errors are reset;
        the control thread stops the arm (stopJ) on its next cycle."""
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
            fresh = self.stream is None
            self.stream = (CommandMode.jog, velocity, None, time.monotonic() + timeout)
        if fresh:
            self._wake.set()

    async def _freedrive(self, timeout: float) -> None:
        with self.lock:
            fresh = self.stream is None
            self.stream = (CommandMode.freedrive, None, None, time.monotonic() + timeout)
        if fresh:
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
        # Slowed along its path where it would pass a joint's limits, never cut short. CPU
        # work on a long trajectory: not under the lock the servo thread takes every 8 ms.
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
            self.scaling.rate, self.scaling.rate_speed = self.speed_ratio, 0.0
            return trajectory_id

    async def _pause_trajectory(self, paused: bool) -> TrajectoryStatus:
        with self.lock:
            running = self.trajectory
            if running is None:
                raise RobotError("no trajectory is running", code="not_running")
            running.state = TrajectoryState.paused if paused else TrajectoryState.running
            return running.status()

    async def _set_digital_output(self, index: int, value: bool) -> None:
        await self._write_output("setStandardDigitalOut", index, value, bit=index)

    async def _set_tool(self, open_: bool) -> None:
        # The tool connector's output 0 closes the gripper (the common wiring).
        await self._write_output("setToolDigitalOut", 0, not open_, bit=TOOL_OUTPUT_0)

    async def _write_output(self, call: str, index: int, value: bool, *, bit: int) -> None:
        """Written from the writer's own process (never this one: see io_writer.py), then
        confirmed by the controller's state, which the answer then shows."""
        with self.lock:
            self._link()
        await self.writer.call(call, index, value)
        deadline = time.monotonic() + OUTPUT_SEEN_WITHIN
        while True:
            with self.lock:
                reading = self.reading
                if reading is not None and bool(reading.digital_outputs >> bit & 1) == value:
                    return
                self._link()
            if time.monotonic() > deadline:
                raise RobotError(f"the controller did not show output {bit} as {value}", code="io")
            await asyncio.sleep(CYCLE / 2)
