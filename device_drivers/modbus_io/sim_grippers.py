"""Simulated grippers on the simulated Modbus device: a Robotiq 2F that speaks its register
protocol, and a gripper on two outputs with grip and open inputs. Their fingers are `Jaws`.
Mounted on a simulated robot (`cell`), closing grasps the part at its TCP in the simulated
cell and opening lets it fall; otherwise a test puts an object between the fingers."""

from __future__ import annotations

from openpendant.device_drivers.modbus_io import robotiq
from openpendant.device_drivers.modbus_io.jaws import Jaws
from openpendant.device_drivers.modbus_io.link import Table
from openpendant.device_drivers.modbus_io.registers import Register, RegisterMap
from openpendant.device_drivers.modbus_io.robotiq import Profile, Request, Status
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.device_drivers.sim_cell.link import CellClient


async def _fingers_move(jaws: Jaws, cell: CellClient | None, closing: bool) -> None:
    """Closing, grasp whatever the cell has between the fingers; opening, let it go."""
    if cell is None:
        return
    if closing:
        answer = await cell.ask("grasp", opening=jaws.at().width)
        part = (answer or {}).get("part")
        jaws.place(float(part["size"][1]) if part else None)
    else:
        await cell.ask("release")
        jaws.place(None)


ACTIVATION_TIME = 0.3  # s; a real 2F takes a few seconds, tests need not wait for that


def _robotiq_map(profile: Profile) -> RegisterMap:
    def word(name: str, table: Table, address: int) -> Register:
        return Register(name=name, table=table, address=address)

    words = range(robotiq.WORDS)
    return RegisterMap(
        model=profile.model,
        unit_id=robotiq.UNIT_ID,
        signals=[
            word(f"request{i}", "holding_register", robotiq.REQUEST_ADDRESS + i) for i in words
        ]
        # The status answers function 3 and 4 alike, as the gripper's does.
        + [word(f"status{i}", "holding_register", robotiq.STATUS_ADDRESS + i) for i in words]
        + [word(f"input{i}", "input_register", robotiq.STATUS_ADDRESS + i) for i in words],
    )


class RobotiqSimulator(ModbusSimulator):
    def __init__(
        self,
        profile: Profile,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        rtu: bool = False,
        cell: CellClient | None = None,
    ) -> None:
        super().__init__(_robotiq_map(profile), host, port, rtu=rtu, cell=cell)
        self.profile = profile
        self.jaws = Jaws(profile.stroke, profile.speed[1])
        self.request = Request()
        self.activated_at: float | None = None  # when the activation finishes
        self.fault = 0

    async def _written(self, table: Table, address: int) -> None:
        first = robotiq.REQUEST_ADDRESS
        if table != "holding_register" or not first <= address < first + robotiq.WORDS:
            return
        held = self.data["holding_register"][first : first + robotiq.WORDS]
        previous, self.request = self.request, Request.of(held)
        acting = bool(self.request.action & robotiq.ACT)
        if not acting:
            self.activated_at, self.fault = None, 0
            self.jaws.halt()
            return
        if not previous.action & robotiq.ACT:  # the rising edge: activation begins
            self.activated_at = self.jaws.clock() + ACTIVATION_TIME
            self.fault = 0
            await _fingers_move(self.jaws, self.cell, closing=False)
            self.jaws.go(self.profile.stroke, self.profile.speed[1])
            return
        if not self._active():
            self.fault = 0x05  # an action before the activation finished
            return
        if self.request.action & robotiq.GTO:
            target = robotiq.count_to_width(self.request.position, self.profile.stroke)
            await _fingers_move(self.jaws, self.cell, target < self.jaws.at().width)
            low, high = self.profile.speed
            self.jaws.go(target, low + (high - low) * self.request.speed / 255)
        else:
            self.jaws.halt()

    def _active(self) -> bool:
        return self.activated_at is not None and self.jaws.clock() >= self.activated_at

    def status(self) -> Status:
        at = self.jaws.at()
        request = self.request
        going = bool(request.action & robotiq.GTO) and self._active()
        if not going or at.moving:
            found = robotiq.MOVING
        elif at.blocked:
            closing = request.position > robotiq.width_to_count(at.width, self.profile.stroke)
            found = robotiq.STOPPED_CLOSING if closing else robotiq.STOPPED_OPENING
        else:
            found = robotiq.AT_POSITION
        activation = robotiq.RESET
        if self.activated_at is not None:
            activation = robotiq.ACTIVE if self._active() else robotiq.ACTIVATING
        return Status(
            activated=bool(request.action & robotiq.ACT),
            going=going,
            activation=activation,
            object=found,
            fault=self.fault,
            echo=request.position,
            position=robotiq.width_to_count(at.width, self.profile.stroke),
            current=30 if at.blocked else 0,
        )

    def _reading(self, table: Table, address: int) -> None:
        if table in ("holding_register", "input_register"):
            words = self.status().words()
            first = robotiq.STATUS_ADDRESS
            self.data["holding_register"][first : first + robotiq.WORDS] = words
            self.data["input_register"][first : first + robotiq.WORDS] = words


class DigitalGripperSimulator(ModbusSimulator):
    """Valves on `close` (and `open`), a grip switch on `gripped`, an end switch on
    `opened`, as the gripper's register map names them."""

    def __init__(
        self, registers: RegisterMap, stroke: float, move_time: float, **where: object
    ) -> None:
        super().__init__(registers, **where)  # type: ignore[arg-type]
        self.speed = stroke / (move_time / 2)  # done well within the move time
        self.jaws = Jaws(stroke, self.speed)
        self.names = {s.name for s in registers.signals}

    async def _written(self, table: Table, address: int) -> None:
        if table != "coil":
            return
        closing = bool(self.get("close"))
        opening = bool(self.get("open")) if "open" in self.names else not closing
        if closing and not opening:
            await _fingers_move(self.jaws, self.cell, closing=True)
            self.jaws.go(0.0, self.speed)
        elif opening and not closing:
            await _fingers_move(self.jaws, self.cell, closing=False)
            self.jaws.go(self.jaws.stroke, self.speed)

    def _reading(self, table: Table, address: int) -> None:
        if table != "discrete_input":
            return
        at = self.jaws.at()
        if "gripped" in self.names:
            self.set("gripped", at.blocked)
        if "opened" in self.names:
            self.set("opened", not at.moving and at.width >= self.jaws.stroke - 1e-6)
