"""One connection to an RR standard robot (`com.robotraconteur.robotics.robot.Robot`): its
`robot_state` wire, its command wires and its calls. Used from the driver's control thread
only (RR's calls block until answered).

An RR wire keeps handing out its last value after the robot has gone (its connection is
only found closed once a call fails, seconds later), so a state counts as new only when
its `seqno` has moved on."""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import RobotRaconteur as RR

from openpendant.plugins.robotraconteur.node import Node
from openpendant.runtime.interfaces.robot import CommandMode, OperationalMode

NAMESPACE = "com.robotraconteur.robotics.robot"
FIRST_STATE_WITHIN = 5.0  # s after connecting
# RR's robot operational modes as the pendant's rules see them: a robot that names no mode
# (undefined, or a cobot's) is jogged as in manual mode, at reduced speed.
OPERATIONAL_MODES = {
    1: OperationalMode.manual_reduced_speed,
    2: OperationalMode.manual_full_speed,
    3: OperationalMode.auto,
}
# Ours → RR's command modes: a trajectory is streamed on the position command wire.
RR_MODES = {
    CommandMode.halt: "halt",
    CommandMode.jog: "jog",
    CommandMode.trajectory: "position_command",
    CommandMode.position_command: "position_command",
    CommandMode.velocity_command: "velocity_command",
}


# RR's robot state flags that say an E-stop stopped it (all but `estop_released`).
ESTOP_FLAGS = (
    "estop",
    *(f"estop_button{n}" for n in range(1, 5)),
    *(f"estop_guard{n}" for n in range(1, 5)),
    "estop_software",
    "estop_fault",
    "estop_internal",
    "estop_other",
)


# What a link that has gone raises (anything else is the robot refusing a command).
LINK_ERRORS = (
    RR.ConnectionException,
    RR.RequestTimeoutException,
    RR.EndpointCommunicationFatalException,
    RR.InvalidEndpointException,
    RR.ServiceNotFoundException,
    RR.NodeNotFoundException,
    RR.ObjectNotFoundException,
)


@dataclass(frozen=True)
class Reading:
    seqno: int  # the robot's own
    received: float  # monotonic, when this process first saw it
    command_mode: int
    operational_mode: OperationalMode
    flags: int
    q: list[float]
    qd: list[float]


class RRLink:
    def __init__(self, node: Node, url: str, user: str | None, password: str | None) -> None:
        self.node = node
        self.client = node.connect(url, user, password)
        try:
            constants = node.constants(NAMESPACE, self.client)
            self.modes: dict[str, int] = dict(constants["RobotCommandMode"])
            self.flag_bits: dict[str, int] = dict(constants["RobotStateFlags"])
            self._command = node.structure(f"{NAMESPACE}.RobotJointCommand", self.client)
            self.state_wire = self.client.robot_state.Connect()
            self.state_wire.WaitInValueValid(FIRST_STATE_WITHIN)
            self._position_wire: Any = None
            self._velocity_wire: Any = None
            self._command_seqno = 0
            self._last: Reading | None = None
            self.read()
        except Exception:
            self.close()
            raise

    def read(self) -> Reading:
        value = self.state_wire.InValue
        seqno = int(value.seqno)
        last = self._last
        if last is not None and last.seqno == seqno:
            return last
        self._last = Reading(
            seqno=seqno,
            received=time.monotonic(),
            command_mode=int(value.command_mode),
            operational_mode=OPERATIONAL_MODES.get(
                int(value.operational_mode), OperationalMode.manual_reduced_speed
            ),
            flags=int(value.robot_state_flags),
            q=np.asarray(value.joint_position, dtype=float).tolist(),
            qd=np.asarray(value.joint_velocity, dtype=float).tolist(),
        )
        return self._last

    def has(self, reading: Reading, flag: str) -> bool:
        bit = self.flag_bits.get(flag, 0)
        return bit != 0 and reading.flags & bit == bit

    def estop(self, reading: Reading) -> bool:
        """Stopped by an E-stop, however the robot names it (`estop`, or only its source)."""
        return any(self.has(reading, flag) for flag in ESTOP_FLAGS)

    def set_mode(self, mode: CommandMode, through_halt: bool = False) -> None:
        """RR's modes change only through halt; `through_halt` halts even where the robot is
        already in the mode wanted (our trajectory and position modes are both RR's
        position_command: one does not go on as the other)."""
        wanted = self.modes[RR_MODES[mode]]
        halt = self.modes["halt"]
        current = int(self.client.command_mode)
        if current == wanted and (wanted == halt or not through_halt):
            return
        if current != halt:
            self.client.command_mode = halt
        if wanted != halt:
            self.client.command_mode = wanted

    def jog(self, velocity: np.ndarray, timeout: float) -> None:
        self.client.jog_joint(velocity, timeout, False)

    def position(self, q: np.ndarray) -> None:
        if self._position_wire is None:
            self._position_wire = self.client.position_command.Connect()
        self._position_wire.OutValue = self._joint_command(q)

    def velocity(self, qd: np.ndarray) -> None:
        if self._velocity_wire is None:
            self._velocity_wire = self.client.velocity_command.Connect()
        self._velocity_wire.OutValue = self._joint_command(qd)

    def _joint_command(self, values: np.ndarray) -> Any:
        """Stamped with the newest state's seqno, which the robot checks (a command more than
        ten states old is dropped)."""
        self._command_seqno += 1
        command = self._command()
        command.seqno = self._command_seqno
        command.state_seqno = self._last.seqno if self._last is not None else 0
        command.command = np.asarray(values, dtype=float)
        return command

    def enable(self) -> None:
        self.client.enable()
        self.client.command_mode = self.modes["halt"]

    def disable(self) -> None:
        self.client.disable()

    def reset_errors(self) -> None:
        self.client.reset_errors()

    def close(self) -> None:
        for wire in (
            getattr(self, "_position_wire", None),
            getattr(self, "_velocity_wire", None),
            getattr(self, "state_wire", None),
        ):
            if wire is not None:
                with contextlib.suppress(Exception):  # a connection already gone
                    wire.Close()
        with contextlib.suppress(Exception):
            self.node.node.DisconnectService(self.client)
