"""The simulated robot driver: SimCore behind a lock, stepped by a 500 Hz thread."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections import deque

import numpy as np

from openpendant.device_drivers.sim_cell.link import CellServer
from openpendant.device_drivers.sim_cell.world import World
from openpendant.device_drivers.sim_robot.core import CYCLE, SimCore
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.limits import CheckedTrajectory, FloatArray
from openpendant.runtime.interfaces.robot import (
    SIM_CELL,
    CommandMode,
    OperationalMode,
    RobotInfo,
    RobotState,
    TrajectoryStatus,
)
from openpendant.runtime.interfaces.robot_driver import RobotDriver, RobotStatus
from openpendant.runtime.kit.errors import RobotError
from openpendant.runtime.robotics.kinematics import Kinematics, se3_to_pose

log = logging.getLogger(__name__)
TOOL_OPENING = 0.1  # m: what the controller's own tool output opens (a generic gripper)


class LoopTimer:
    """Start-to-start periods of the control loop, for the period-error figure."""

    def __init__(self, size: int = 20_000) -> None:
        self.periods: deque[float] = deque(maxlen=size)
        self.overruns = 0
        self._last: float | None = None

    def reset(self) -> None:
        self.periods.clear()
        self.overruns = 0
        self._last = None

    def tick(self, now: float) -> None:
        if self._last is not None:
            self.periods.append(now - self._last)
        self._last = now

    def stats(self) -> dict[str, float]:
        if not self.periods:
            return {"cycles": 0}
        error_ms = np.abs(np.array(self.periods) - CYCLE) * 1000.0
        return {
            "cycles": len(error_ms),
            "period_ms": CYCLE * 1000.0,
            "error_p50_ms": float(np.percentile(error_ms, 50)),
            "error_p99_ms": float(np.percentile(error_ms, 99)),
            "error_max_ms": float(error_ms.max()),
            "overruns": self.overruns,
        }


class SimRobot(RobotDriver):
    def __init__(self, identity: DeviceIdentity, info: RobotInfo, *, time_scale: int = 1) -> None:
        """`time_scale`: control cycles per period while a trajectory runs (states keep
        wall-clock stamps, so staleness and the deadman are as in real time)."""
        if SIM_CELL not in info.capabilities:  # its parts are listed for the 3D view
            info = info.model_copy(update={"capabilities": [*info.capabilities, SIM_CELL]})
        super().__init__(identity, info)
        self.core = SimCore(info, Kinematics(info))
        self.lock = threading.Lock()
        self.timer = LoopTimer()
        self.time_scale = time_scale
        self._running = threading.Event()
        self._thread: threading.Thread | None = None
        # The parts around it, which its tool and a simulated gripper on it pick.
        self.world = World(self._tcp, flange=self._flange)
        self.cell = CellServer(self.world, identity.name)

    def _tcp(self) -> Pose:
        with self.lock:
            position = self.core.tracker.position.copy()
            kinematics = self.core.kinematics
        return kinematics.tcp_pose(position)

    def _flange(self) -> Pose:
        with self.lock:
            position = self.core.tracker.position.copy()
            kinematics = self.core.kinematics
        return se3_to_pose(kinematics.flange(position))

    async def start(self) -> None:
        self._running.set()
        self._thread = threading.Thread(target=self._loop, name="sim-control", daemon=True)
        self._thread.start()
        try:
            await self.cell.start()
        except OSError as exc:  # another simulated robot of this name and data directory
            log.warning("no simulated cell for %s: %s", self.identity.name, exc)

    async def shutdown(self) -> None:
        await self.halt()
        await self.cell.stop()
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def _loop(self) -> None:
        deadline = time.perf_counter()
        while self._running.is_set():
            start = time.perf_counter()
            self.timer.tick(start)
            with self.lock:
                try:
                    self.cycle(time.monotonic())
                except Exception as exc:
                    # The loop must outlive any bug in a cycle: fault the robot, keep running.
                    log.exception("control cycle failed")
                    self.core.fault(f"control loop error: {exc}")
            deadline += CYCLE
            delay = deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            elif delay < -CYCLE:
                # Late by more than a cycle: start afresh instead of bursting to catch up.
                self.timer.overruns += 1
                deadline = time.perf_counter()

    def cycle(self, now: float) -> None:
        """One period of the control loop (the caller holds the lock): one control cycle, or
        `time_scale` of them along a trajectory. Only there: a stream's commands (a jog, a
        Move to) and their deadlines are in real time."""
        self.core.step(now)
        for _ in range(self.time_scale - 1):
            if self.core.mode is not CommandMode.trajectory:
                break
            self.core.step(now)

    def state(self) -> RobotState:
        with self.lock:
            snapshot = self.core.snapshot()
        return snapshot.to_state(self.core.kinematics)

    def status(self) -> RobotStatus:
        with self.lock:
            core = self.core
            return RobotStatus(
                core.flags(), core.mode, core.error_message, core.tracker.position.tolist()
            )

    async def trajectory_status(self, trajectory_id: str) -> TrajectoryStatus:
        with self.lock:
            return self.core.trajectory_status(trajectory_id)

    async def _enable(self) -> None:
        with self.lock:
            self.core.enable()

    async def _disable(self) -> None:
        with self.lock:
            self.core.disable()

    async def _reset_errors(self) -> None:
        with self.lock:
            self.core.reset_errors()

    async def _halt(self) -> None:
        with self.lock:
            self.core.halt()

    async def _protective_stop(self, reason: str) -> None:
        with self.lock:
            self.core.protective_stop(reason)

    async def _set_command_mode(self, mode: CommandMode) -> None:
        with self.lock:
            self.core.set_mode(mode)

    async def _set_speed_ratio(self, ratio: float) -> None:
        with self.lock:
            self.core.set_speed_ratio(ratio)

    async def _jog_joint(self, velocity: FloatArray, timeout: float) -> None:
        with self.lock:
            self.core.stream(CommandMode.jog, velocity, None, timeout, time.monotonic())

    async def _freedrive(self, timeout: float) -> None:
        with self.lock:
            zero = np.zeros(len(self.info.joints))
            self.core.stream(CommandMode.freedrive, zero, None, timeout, time.monotonic())

    async def _velocity_command(self, velocity: FloatArray, timeout: float) -> None:
        with self.lock:
            self.core.stream(
                CommandMode.velocity_command, velocity, None, timeout, time.monotonic()
            )

    async def _position_command(
        self, position: FloatArray, velocity: FloatArray | None, timeout: float
    ) -> None:
        with self.lock:
            self.core.stream(
                CommandMode.position_command, velocity, position, timeout, time.monotonic()
            )

    async def _pause_trajectory(self, paused: bool) -> TrajectoryStatus:
        with self.lock:
            return self.core.pause_trajectory(paused)

    async def _execute_trajectory(self, trajectory: CheckedTrajectory) -> str:
        prepared_since = self.interruptions
        reference = await asyncio.to_thread(self.core.prepare, trajectory)  # not under the lock
        with self.lock:
            self._refuse_if_interrupted(prepared_since)
            return self.core.start_trajectory(trajectory, reference)

    async def _set_tool_setup(self, info: RobotInfo) -> None:
        kinematics = await asyncio.to_thread(Kinematics, info)  # loads the URDF: not under the lock
        with self.lock:
            self.core.info = info
            self.core.kinematics = kinematics

    async def _set_tool(self, open_: bool) -> None:
        with self.lock:
            self.core.tool_open = open_
        if open_:
            self.world.release()
        else:
            self.world.grasp(TOOL_OPENING)

    async def _set_digital_output(self, index: int, value: bool) -> None:
        with self.lock:
            self.core.digital_outputs[index] = value

    # Simulation controls (the physical E-stop button, key switch and faults) ------------------

    def set_digital_input(self, index: int, value: bool) -> None:
        """What a sensor wired to the controller would do."""
        with self.lock:
            if not 0 <= index < len(self.core.digital_inputs):
                raise RobotError(f"no digital input {index}", code="unknown_io")
            self.core.digital_inputs[index] = value

    def place(self, position: list[float]) -> None:
        with self.lock:
            self.core.place(np.asarray(position, dtype=float))

    def push(self, velocity: list[float]) -> None:
        with self.lock:
            self.core.push(np.asarray(velocity, dtype=float))

    def set_estop(self, engaged: bool) -> None:
        with self.lock:
            self.core.set_estop(engaged)

    def inject_fault(self, message: str) -> None:
        with self.lock:
            self.core.fault(message)

    def set_operational_mode(self, mode: OperationalMode) -> None:
        with self.lock:
            self.core.set_operational_mode(mode)
