"""The emulated controller: an arm stepped at 500 Hz under its joint limits (the simulated
robot's ruckig tracker), its modes, I/O and RTDE registers, and the state machine of
ur-rtde's control script running on it (command code in input_int_register_0, status in
output_int_register_0: 1 ready, 2 done; docs/dev/ur-rtde-protocol.md §3)."""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.ur_rtde.emulator.servo import ServoJ, ServoJump
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.robot import JointLimits, RobotInfo
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.tracker import JointTracker, TrackerError

log = logging.getLogger(__name__)
CYCLE = 0.002  # s: an e-Series controller's 500 Hz

# robot_mode, safety_mode, runtime_state (UR's RTDE guide)
POWER_OFF, IDLE, RUNNING = 3, 5, 7
NORMAL, REDUCED, PROTECTIVE_STOP, SYSTEM_EMERGENCY_STOP = 1, 2, 3, 6
MOVING = frozenset({NORMAL, REDUCED})  # safety modes the arm may move in
STOPPED, PLAYING = 1, 2
# safety_status_bits
BIT_NORMAL, BIT_REDUCED, BIT_PROTECTIVE, BIT_SYSTEM_ESTOP, BIT_ESTOP = 0, 1, 2, 5, 7

READY, DONE = 1, 2
MOVEJ, MOVEJ_IK, MOVEL, MOVEL_FK = 1, 2, 3, 4
SERVOJ, SPEEDJ, SPEEDL, SPEED_STOP, SERVO_STOP = 11, 9, 10, 15, 16
TEACH_MODE, END_TEACH_MODE = 18, 19
PROTECTIVE_STOP_CMD, STOPL, STOPJ, SET_WATCHDOG = 31, 33, 34, 35
FREEDRIVE_MODE, END_FREEDRIVE_MODE, GET_FREEDRIVE_STATUS = 52, 53, 54
STOP_SCRIPT = 255
# Re-run every cycle while in the register; the script stays ready (its "realtime" set).
REALTIME = frozenset({24, 11, 9, 10, 6, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71})
RECORD_LIMIT = 60_000  # cycles of joint positions a recording keeps (two minutes)
# The arm's acceleration and jerk over the robot file's, which are conservative values for
# planning (the controller has its own): a servoJ stream planned at those limits overshoots
# them a little between its targets (up to 3 % seen), and is still followed as it is.
ARM_HEADROOM = 1.1
CATCH_UP = 0.1  # s


@dataclass
class Motion:
    kind: str = "hold"  # hold, to, velocity, servo
    target: np.ndarray = field(default_factory=lambda: np.zeros(0))
    speed: float = 0.0  # rad/s for "to"


class Controller:
    def __init__(
        self,
        info: RobotInfo,
        version: tuple[int, int, int, int] = (5, 15, 0, 12345),
        serial: str = "20185500000",
    ) -> None:
        self.info, self.version, self.serial = info, version, serial
        self.kinematics = Kinematics(info)
        self.tracker = JointTracker(
            [_capable(j) for j in info.joints], CYCLE, np.array(info.home, dtype=float)
        )
        self.lock = threading.RLock()
        self.started = time.monotonic()
        self.robot_mode = RUNNING
        self.safety_mode = NORMAL
        self.runtime_state = STOPPED
        self.in_int = [0] * 48
        self.in_double = [0.0] * 48
        self.out_int = [0] * 48
        self.out_double = [0.0] * 48
        self.digital_outputs = 0  # standard 0-7, configurable 8-15, tool 16-17
        self.digital_inputs = 0
        self.speed_fraction = 1.0
        # The standard analog outputs as the script sets them: a ratio of the range and
        # whether the output is in its voltage (0-10 V) or current (4-20 mA) domain.
        self.analog_outputs = [0.0, 0.0]
        self.analog_output_voltage = [True, True]
        self.analog_inputs = [0.0, 0.0]  # in the inputs' units (V or mA)
        self.offset = 0  # the script's register offset (24: the upper range)
        self.input_owners: dict[str, object] = {}  # RTDE input field -> the connection owning it
        self.executing = False
        self.move_blocking = False  # a blocking move whose end is signalled "done"
        self.motion = Motion()
        arm = self.tracker
        self.servo = ServoJ(CYCLE, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
        # The arm's joint positions, one a cycle, while a test or benchmark records them.
        self.recording: list[list[float]] | None = None
        self.operational_mode = "NONE"  # no mode selection configured (UR's default)
        self.freedrive = False
        self.hand = np.zeros(len(info.joints))  # a hand pushing the arm (moves it in teach mode)
        self.watchdog_hz: float | None = None
        self.last_kick = 0.0
        self.commands: list[int] = []  # every command code the script took, in order
        # When each realtime command last began (monotonic: the same clock in every process
        # of this computer, so a client can time its commands' way here).
        self.started_at: dict[int, float] = {}
        self.scripts = 0  # control scripts received
        self._running = threading.Event()
        self._thread: threading.Thread | None = None

    # Registers, as the script sees them --------------------------------------------------

    def cmd(self) -> int:
        return self.in_int[self.offset]

    def d(self, n: int) -> float:
        return self.in_double[self.offset + n]

    def i(self, n: int) -> int:
        return self.in_int[self.offset + n]

    def vector(self, first: int = 0) -> np.ndarray:
        return np.array([self.d(first + k) for k in range(6)])

    def status(self, value: int) -> None:
        self.out_int[self.offset] = value

    # The world's side (tests) ------------------------------------------------------------

    def protective_stop(self) -> None:
        with self.lock:
            self.safety_mode = PROTECTIVE_STOP
            self._program_stops()

    def reduced_mode(self, on: bool) -> None:
        """The safety system switches to its reduced limits (a safeguard input, a plane
        crossed) and back."""
        with self.lock:
            if on and self.safety_mode == NORMAL:
                self.safety_mode = REDUCED
            elif not on and self.safety_mode == REDUCED:
                self.safety_mode = NORMAL

    def emergency_stop(self, engaged: bool) -> None:
        with self.lock:
            if engaged:
                self.safety_mode = SYSTEM_EMERGENCY_STOP
                self.robot_mode = POWER_OFF
                self._program_stops()
            elif self.safety_mode == SYSTEM_EMERGENCY_STOP:
                self.safety_mode = NORMAL  # power on and brake release bring it back

    def reset(self) -> None:
        """Powered, in normal mode, no program running, the arm at rest where it is."""
        with self.lock:
            self._program_stops()
            self.robot_mode, self.safety_mode = RUNNING, NORMAL
            self.digital_inputs = self.digital_outputs = 0
            self.speed_fraction = 1.0
            self.hand[:] = 0.0
            self.operational_mode = "NONE"
            self.watchdog_hz = None
            self.in_int = [0] * 48
            self.tracker.place(self.tracker.position)

    def _program_stops(self) -> None:
        self.runtime_state = STOPPED
        self.executing = self.move_blocking = False
        self.freedrive = False
        self.motion = Motion()

    # The script --------------------------------------------------------------------------

    def script_received(self, text: str) -> None:
        """A program sent to the script port: ur-rtde's control script starts running
        (when the robot can run one)."""
        with self.lock:
            self.scripts += 1
            if "def rtde_control():" not in text:
                log.info("a script that is not ur-rtde's control script: ignored")
                return
            self.offset = 24 if "# int register offset\n24" in text else 0
            if self.robot_mode != RUNNING or self.safety_mode not in MOVING:
                log.info(
                    "script not started: robot mode %d, safety mode %d",
                    self.robot_mode,
                    self.safety_mode,
                )
                return
            self.runtime_state = PLAYING
            self.executing = self.move_blocking = False
            self.watchdog_hz = None
            self.out_int[self.offset + 2] = 0x10000  # async progress reset: "finished"
            self.status(READY)

    def stop_program(self) -> None:
        with self.lock:
            self._program_stops()

    def inputs_written(self, names: list[str]) -> None:
        """An input package arrived: it feeds the watchdog if it holds the command
        register (as the controller's rtde_set_watchdog watches that register)."""
        if f"input_int_register_{self.offset}" in names:
            self.last_kick = time.monotonic()
            if self.cmd() == SERVOJ:  # each one, in order (servo.py says why)
                # servoj(q, a, v, t, lookahead_time, gain): D6, D7 unused, D10 see servo.py
                self.servo.command(self.vector(), self.d(8), self.d(9))

    def _process(self, cmd: int) -> None:
        """A command that is not re-run every cycle, once."""
        self.commands.append(cmd)
        if cmd in (MOVEJ, MOVEL_FK):
            target = self.vector()
            self.motion = Motion("to", target, self.d(6))
            self.move_blocking = not self.i(1)
            if not self.move_blocking:
                self._async_progress(0)
                self.status(DONE)
            return
        if cmd in (STOPJ, STOPL, SPEED_STOP, SERVO_STOP):
            self.motion = Motion()
        elif cmd in (TEACH_MODE, FREEDRIVE_MODE):
            self.freedrive = True
            self.motion = Motion()
        elif cmd in (END_TEACH_MODE, END_FREEDRIVE_MODE):
            self.freedrive = False
        elif cmd == GET_FREEDRIVE_STATUS:
            self.out_int[self.offset + 1] = int(self.freedrive)
        elif cmd == SET_WATCHDOG:
            self.watchdog_hz = self.d(0) if self.d(0) > 0 else None
            self.last_kick = time.monotonic()
        elif cmd == PROTECTIVE_STOP_CMD:
            self.safety_mode = PROTECTIVE_STOP
            self._program_stops()
            return
        elif cmd == STOP_SCRIPT:
            self._program_stops()
            return
        else:
            log.info("command %d is not emulated: taken as done", cmd)
        self.status(DONE)

    def _async_progress(self, value: int) -> None:
        running = 0x8000 | min(value, 0x7FFF) if value >= 0 else 0
        self.out_int[self.offset + 2] = (1 << 16) | running

    def _realtime(self, cmd: int) -> None:
        if not self.commands or self.commands[-1] != cmd:  # once per run of cycles
            self.commands.append(cmd)
            self.started_at[cmd] = time.monotonic()
        if cmd == SPEEDJ:
            self.motion = Motion("velocity", self.vector())
        elif cmd == SERVOJ:
            if self.motion.kind != "servo":  # the script's servo thread starts
                self.servo.start()
            self.motion = Motion("servo", self.vector())  # its targets: `inputs_written`
        elif cmd == SPEEDL:
            # The TCP twist as joint velocities through the Jacobian at this pose.
            jacobian = self.kinematics.jacobian(self.tracker.position)
            qd = np.linalg.lstsq(jacobian, self.vector(), rcond=None)[0]
            self.motion = Motion("velocity", qd)
        self.status(READY)

    def _script_cycle(self) -> None:
        if self.runtime_state != PLAYING:
            return
        if self.watchdog_hz and time.monotonic() - self.last_kick > 1.0 / self.watchdog_hz:
            log.warning(
                "watchdog: no command update for %.3f s, program stopped",
                time.monotonic() - self.last_kick,
            )
            self._program_stops()
            return
        cmd = self.cmd()
        if cmd in REALTIME:
            self._realtime(cmd)
        elif cmd == 0:
            self.executing = False
            if not self.move_blocking:
                self.status(READY)
        elif not self.executing:
            self.executing = True
            self._process(cmd)

    # Motion --------------------------------------------------------------------------------

    def _move_cycle(self) -> None:
        m = self.motion
        scale = self.speed_fraction
        try:
            if m.kind == "to":
                limit = np.full(len(m.target), max(m.speed * scale, 1e-6))
                self.tracker.step_toward(m.target, limit)
                if self.tracker.settled(np.clip(m.target, self.tracker.lower, self.tracker.upper)):
                    self.motion = Motion()
                    if self.move_blocking:
                        self.move_blocking = False
                        self.status(DONE)
                    else:
                        self._async_progress(-1)
            elif m.kind == "velocity":
                self.tracker.step_velocity(m.target * scale)
                at_limit = (self.tracker.position <= self.tracker.lower + 1e-4) & (m.target < 0) | (
                    self.tracker.position >= self.tracker.upper - 1e-4
                ) & (m.target > 0)
                if at_limit.any():  # a joint driven into its limit: the safety system stops
                    self.safety_mode = PROTECTIVE_STOP
                    self._program_stops()
            elif m.kind == "servo":
                t = self.tracker
                t.follow(*self.servo.step((t.position, t.velocity, t.acceleration)))
            else:
                self.tracker.hold()
        except (TrackerError, ServoJump) as exc:
            log.error("emulated arm: %s", exc)
            self.safety_mode = PROTECTIVE_STOP
            self._program_stops()

    def step(self) -> None:
        with self.lock:
            self._script_cycle()
            if self.motion.kind != "servo":  # servoj commands for a program that ran none
                self.servo.pending.clear()
            if self.robot_mode != RUNNING or self.safety_mode not in MOVING:
                self.tracker.hold()
            elif self.freedrive:
                self.tracker.step_velocity(self.hand)  # teach mode: where the hand takes it
            else:
                self._move_cycle()
            if self.recording is not None and len(self.recording) < RECORD_LIMIT:
                self.recording.append(self.tracker.position.tolist())

    def place(self, position: np.ndarray) -> bool:
        """The arm put at `position` at once, at rest (a test's set-up, not a motion): only
        while it is still and nothing moves it."""
        with self.lock:
            if self.motion.kind != "hold" or self.freedrive or self.tracker.moving:
                return False
            self.tracker.place(np.clip(position, self.tracker.lower, self.tracker.upper))
            return True

    def record(self, on: bool) -> list[list[float]]:
        """Start recording the arm's joint positions (one a cycle, afresh), or stop and
        return what was recorded."""
        with self.lock:
            recorded, self.recording = self.recording or [], [] if on else None
            return [] if on else recorded

    def run(self) -> None:
        self._running.set()
        self._thread = threading.Thread(target=self._loop, name="ur-emulator", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def _loop(self) -> None:
        deadline = time.perf_counter()
        while self._running.is_set():
            self.step()
            deadline += CYCLE
            delay = deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            elif delay < -CATCH_UP:  # held up for long: that time is lost
                deadline = time.perf_counter()
            # Held up for less, it catches up (cycles back to back), as a controller's
            # clock, real-time, would not have lost that time.

    def tcp(self) -> Pose:
        """The TCP in the base frame (the simulated cell's frame)."""
        with self.lock:
            q = self.tracker.position.copy()
        return self.kinematics.tcp_pose(q)

    # What RTDE streams -------------------------------------------------------------------

    def outputs(self) -> dict[str, object]:
        with self.lock:
            q = self.tracker.position.copy()
            qd = self.tracker.velocity.copy()
            qdd = self.tracker.acceleration.copy()
            pose = self.kinematics.tcp_pose(q)
            safety_bits = 1 << {
                NORMAL: BIT_NORMAL,
                REDUCED: BIT_REDUCED,
                PROTECTIVE_STOP: BIT_PROTECTIVE,
                SYSTEM_EMERGENCY_STOP: BIT_SYSTEM_ESTOP,
            }.get(self.safety_mode, BIT_NORMAL)
            if self.safety_mode == SYSTEM_EMERGENCY_STOP:
                safety_bits |= 1 << BIT_ESTOP
            powered = self.robot_mode != POWER_OFF
            values: dict[str, object] = {
                "timestamp": time.monotonic() - self.started,
                "target_q": tuple(q),
                "actual_q": tuple(q),
                "target_qd": tuple(qd),
                "actual_qd": tuple(qd),
                "target_qdd": tuple(qdd),
                "actual_qdd": tuple(qdd),
                "actual_TCP_pose": tuple(_rotvec_pose(pose)),
                "target_TCP_pose": tuple(_rotvec_pose(pose)),
                "robot_mode": self.robot_mode,
                "safety_mode": self.safety_mode,
                "runtime_state": self.runtime_state,
                "robot_status_bits": int(powered) | (int(self.runtime_state == PLAYING) << 1),
                "safety_status_bits": safety_bits,
                "actual_digital_input_bits": self.digital_inputs,
                "actual_digital_output_bits": self.digital_outputs,
                "speed_scaling": self.speed_fraction,
                "target_speed_fraction": self.speed_fraction,
                "standard_analog_input0": self.analog_inputs[0],
                "standard_analog_input1": self.analog_inputs[1],
                "standard_analog_output0": self.analog_out(0),
                "standard_analog_output1": self.analog_out(1),
                "joint_mode": (253,) * 6 if powered else (236,) * 6,
            }
            for n in range(48):
                values[f"output_int_register_{n}"] = self.out_int[n]
                values[f"output_double_register_{n}"] = self.out_double[n]
            return values

    def apply_inputs(self, fields: dict[str, object]) -> None:
        with self.lock:
            for name, value in fields.items():
                if name.startswith("input_int_register_"):
                    self.in_int[int(name.rsplit("_", 1)[1])] = int(value)  # type: ignore[call-overload]
                elif name.startswith("input_double_register_"):
                    self.in_double[int(name.rsplit("_", 1)[1])] = float(value)  # type: ignore[arg-type]
            self._masked(fields, "standard_digital_output", 0)
            self._masked(fields, "configurable_digital_output", 8)
            self._masked(fields, "tool_digital_output", 16)
            if fields.get("speed_slider_mask"):
                self.speed_fraction = min(max(float(fields["speed_slider_fraction"]), 0.0), 1.0)  # type: ignore[arg-type]
            mask = int(fields.get("standard_analog_output_mask", 0))  # type: ignore[call-overload]
            voltage = int(fields.get("standard_analog_output_type", 0))  # type: ignore[call-overload]
            for k in (0, 1):
                if mask & (1 << k) and f"standard_analog_output_{k}" in fields:
                    ratio = float(fields[f"standard_analog_output_{k}"])  # type: ignore[arg-type]
                    self.analog_outputs[k] = min(max(ratio, 0.0), 1.0)
                    self.analog_output_voltage[k] = bool(voltage & (1 << k))
            self.inputs_written(list(fields))

    def analog_out(self, k: int) -> float:
        """What the controller reports: the output in its domain's unit (V or mA)."""
        if self.analog_output_voltage[k]:
            return 10.0 * self.analog_outputs[k]
        return 4.0 + 16.0 * self.analog_outputs[k]

    def _masked(self, fields: dict[str, object], name: str, shift: int) -> None:
        mask = int(fields.get(f"{name}_mask", 0))  # type: ignore[call-overload]
        if mask and name in fields:
            value = int(fields[name])  # type: ignore[call-overload]
            self.digital_outputs = (self.digital_outputs & ~(mask << shift)) | (
                (value & mask) << shift
            )


def _capable(joint: JointLimits) -> JointLimits:
    jerk = None if joint.max_jerk is None else joint.max_jerk * ARM_HEADROOM
    return joint.model_copy(
        update={"max_acceleration": joint.max_acceleration * ARM_HEADROOM, "max_jerk": jerk}
    )


def _rotvec_pose(pose: Pose) -> list[float]:
    """A Pose as UR writes it: x, y, z and the rotation vector."""
    rotvec = Rotation.from_quat(pose.orientation).as_rotvec()
    return [*pose.position, *(float(v) for v in rotvec)]
