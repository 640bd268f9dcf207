"""A simulated six-joint arm served as a Robot Raconteur standard robot
(`com.robotraconteur.robotics.robot.Robot`), written on `robotraconteur-abstract-robot` as
RR's own Python drivers are: the stand-in for a real RR robot in the RR tests.

`python -m tests.support.rr_sim_arm PORT` serves it on 127.0.0.1:PORT as service `robot` and
prints `READY` once it does. SIGUSR1 presses its E-stop, SIGUSR2 releases it (then it must be
enabled again); SIGTERM ends it. Its robot info: rr_sim_arm.yml (a UR5's chain and limits).

The arm goes where it is told at once, within its joint speed limits, once per 10 ms step.
Abstract robot 0.2.2's slips are mended here: `halt()` and `home()` missing, the operational
mode read from a misspelt field, the controller state and errors served as methods instead
of properties (clients got type errors), and the velocity command mode's misspelt field,
which killed the control loop (the state then froze while clients stayed connected)."""

from __future__ import annotations

import signal
import sys
import threading
from pathlib import Path
from typing import Any

import general_robotics_toolbox as rox
import numpy as np
import RobotRaconteur as RR
from robotraconteur_abstract_robot import AbstractRobot
from RobotRaconteurCompanion.Util.AttributesUtil import AttributesUtil
from RobotRaconteurCompanion.Util.InfoFileLoader import InfoFileLoader

from openpendant.plugins.robotraconteur.node import Node

INFO = Path(__file__).with_name("rr_sim_arm.yml")
START = np.array([0.0, -1.2, 1.4, -1.8, -1.57, 0.0])  # rad: a UR's usual ready pose
PERIOD = 0.01  # s per control step
ROBOT_TYPE = "com.robotraconteur.robotics.robot.Robot"


class SimArm(AbstractRobot):  # type: ignore[misc]
    _wire_velocity_command_last_ep: Any  # the base class's

    def __init__(self, info: Any, node: Any) -> None:
        super().__init__(info, len(START), node)
        self._uses_homing = False
        self._has_position_command = True
        self._has_velocity_command = True
        self._has_jog_command = True
        self._update_period = PERIOD
        self._base_set_operational_mode = True
        self._base_set_controller_state = True
        limits = [j.joint_limits for j in info.joint_info]
        self._speed_limit = np.array([j.velocity for j in limits])
        self._lower = np.array([j.lower for j in limits])
        self._upper = np.array([j.upper for j in limits])
        self._q = START.copy()
        self._qd = np.zeros(len(START))
        self._target: np.ndarray | None = None
        self._velocity_target: np.ndarray | None = None
        self._last: float | None = None
        self._estop_pressed = False
        self._powered = True
        self._drives_on = True  # off: enabled, but not ready (its drives lost their power)
        self._mode_name = "cobot"  # its operational mode, as a key switch would set it
        self._base_set_operational_mode = False
        self._extra_flags = 0  # RR state flags the test sets (a fatal error, an E-stop's source)
        self._modes_set: list[int] = []  # every command mode a client set, in order

    def _run_timestep(self, now: float) -> None:
        dt = PERIOD if self._last is None else max(0.0, now - self._last)
        self._last = now
        with self._lock:
            if self._estop_pressed or not self._powered or not self._drives_on or self._extra_flags:
                self._target = self._velocity_target = None
            if self._target is not None:
                reach = self._speed_limit * dt
                step = np.clip(self._target - self._q, -reach, reach)
            elif self._velocity_target is not None:
                step = np.clip(self._velocity_target, -self._speed_limit, self._speed_limit) * dt
            else:
                step = np.zeros(len(START))
            self._q = np.clip(self._q + step, self._lower, self._upper)
            self._qd = step / dt if dt > 0 else np.zeros(len(START))
            self._target = self._velocity_target = None  # each command holds for one step
            self._joint_position = self._q.copy()
            self._joint_velocity = self._qd.copy()
            self._joint_effort = np.zeros(len(START))
            tcp = rox.fwdkin(self._rox_robots[0], self._q)
            self._endpoint_pose = [self._geometry_util.rox_transform_to_pose(tcp)]
            self._endpoint_vel = [np.zeros((1,), dtype=self._spatial_velocity_dtype)[0]]
            self._last_joint_state = self._last_robot_state = self._last_endpoint_state = now
            self._stopped = self._estop_pressed
            self._estop_source = 1 if self._estop_pressed else 0
            self._error = False
            self._enabled = self._powered and not self._estop_pressed
            self._ready = self._enabled and self._drives_on
            self._operational_mode = self._robot_operational_mode[self._mode_name]
        super()._run_timestep(now)

    def _fill_state_flags(self, now: float) -> int:
        flags: int = super()._fill_state_flags(now)
        return flags | self._extra_flags

    def _send_robot_command(self, now: float, position: Any, velocity: Any) -> None:
        with self._lock:
            self._target = None if position is None else np.array(position, dtype=float)
            self._velocity_target = None if velocity is None else np.array(velocity, dtype=float)
            self._position_command = None if position is None else np.array(position, dtype=float)
            self._velocity_command = None if velocity is None else np.array(velocity, dtype=float)

    def _fill_robot_command(self, now: float) -> tuple[bool, Any, Any]:
        if self._command_mode != self._robot_command_mode["velocity_command"]:
            filled: tuple[bool, Any, Any] = super()._fill_robot_command(now)
            return filled
        self._wire_position_command_sent = self._wire_velocity_command_sent = False
        self._trajectory_valid = False
        ok, command, _, endpoint = self.velocity_command.TryGetInValue()
        if not ok:
            return True, None, None
        last_endpoint: Any = self._wire_velocity_command_last_ep
        if last_endpoint != endpoint:
            self._wire_velocity_command_last_ep = endpoint
            self._wire_velocity_command_last_seqno = 0
        if (
            command is None
            or command.seqno < self._wire_velocity_command_last_seqno
            or abs(int(command.state_seqno) - int(self._state_seqno)) > 10
            or len(command.command) != self._joint_count
        ):
            return True, None, None
        self._wire_velocity_command_last_seqno = command.seqno
        self._wire_velocity_command_sent = True
        return True, None, np.array(command.command) * self._speed_ratio

    def _send_disable(self, handler: Any) -> None:
        with self._lock:
            self._powered = False
        self._node.PostToThreadPool(lambda: handler(None))

    def _send_enable(self, handler: Any) -> None:
        with self._lock:
            pressed = self._estop_pressed
            refused = RR.InvalidOperationException("E-stop pressed") if pressed else None
            if refused is None:
                self._powered = True
        self._node.PostToThreadPool(lambda: handler(refused))

    def _send_reset_errors(self, handler: Any) -> None:
        self._node.PostToThreadPool(lambda: handler(None))

    def halt(self) -> None:
        with self._lock:
            self._command_mode = self._robot_command_mode["halt"]

    def home(self) -> None:
        raise RR.NotImplementedException("this arm needs no homing")

    @property
    def operational_mode(self) -> Any:
        return self._operational_mode

    @property
    def command_mode(self) -> Any:
        return AbstractRobot.command_mode.fget(self)

    @command_mode.setter
    def command_mode(self, value: Any) -> None:
        AbstractRobot.command_mode.fset(self, value)
        with self._lock:
            self._modes_set.append(int(value))

    def getf_param(self, name: str) -> Any:
        """`modes_set`: the command modes clients set, in order (RR's numbers)."""
        if name != "modes_set":
            raise RR.InvalidArgumentException(f"no parameter {name!r}")
        with self._lock:
            return RR.VarValue(np.array(self._modes_set, dtype=np.int32), "int32[]")

    @property
    def controller_state(self) -> Any:
        return self._controller_state

    @property
    def current_errors(self) -> list[Any]:
        return []

    def setf_param(self, name: str, value: Any) -> None:
        """The test's hands on the arm: `drives` (0: off, 1: on), `operational_mode` (a
        name of RR's RobotOperationalMode, as a key switch sets it) and `flags` (RR's
        RobotStateFlags bits its states carry besides its own; the arm stands still while
        any is set, as a robot with a fatal error or an E-stop would)."""
        with self._lock:
            if name == "drives":
                self._drives_on = bool(value.data[0])
            elif name == "flags":
                self._extra_flags = int(value.data[0])
            elif name == "operational_mode":
                self._mode_name = str(value.data)
            else:
                raise RR.InvalidArgumentException(f"no parameter {name!r}")

    def press_estop(self, pressed: bool) -> None:
        with self._lock:
            self._estop_pressed = pressed
            if pressed:
                self._powered = False


def main(port: int) -> None:
    node = Node("openpendant_rr_sim_arm", serve_port=port, localhost_only=True)
    info, _ = InfoFileLoader(node.node).LoadInfoFile(str(INFO), f"{ROBOT_TYPE}Info", "device")
    arm = SimArm(info, node.node)
    arm._start_robot()
    context = node.node.RegisterService("robot", ROBOT_TYPE, arm)
    attributes = AttributesUtil(node.node).GetDefaultServiceAttributesFromDeviceInfo(
        info.device_info
    )
    context.SetServiceAttributes(attributes)
    done = threading.Event()
    signal.signal(signal.SIGUSR1, lambda *_: arm.press_estop(True))
    signal.signal(signal.SIGUSR2, lambda *_: arm.press_estop(False))
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    print("READY", flush=True)
    done.wait()
    arm._close()
    node.close()


if __name__ == "__main__":
    main(int(sys.argv[1]))
