"""A gripper on Modbus as the driver host starts it (`openpendant driver modbus-gripper`):
a Robotiq 2F-85 / 2F-140, or a gripper on a block's digital outputs and inputs (`digital`,
with a register map). With `--simulate` it serves a simulated one on pymodbus's server and
drives it over the real protocol."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from fastapi import APIRouter
from pydantic import BaseModel, Field

from openpendant.device_drivers.modbus_io import robotiq
from openpendant.device_drivers.modbus_io.digital_gripper import DigitalGripper, load_gripper_map
from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.entry import LinkOptions
from openpendant.device_drivers.modbus_io.link import ModbusLink
from openpendant.device_drivers.modbus_io.robotiq_gripper import RobotiqGripper
from openpendant.device_drivers.modbus_io.sim_grippers import (
    DigitalGripperSimulator,
    RobotiqSimulator,
)
from openpendant.device_drivers.sim_cell.link import CellClient
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.gripper import GripperDriver, GripperState
from openpendant.runtime.paths import MODBUS_MAPS_DIR

DIGITAL_MAP = MODBUS_MAPS_DIR / "digital_gripper.yaml"
ProfileName = Literal["robotiq-2f-85", "robotiq-2f-140", "digital"]


class ModbusGripperOptions(LinkOptions):
    profile: ProfileName = Field(default="robotiq-2f-85", description="which gripper it is")
    map: Path | None = Field(
        default=None, description="register map of a digital gripper (default: close/open/gripped)"
    )
    mounted_on: str = Field(
        default="",
        max_length=64,
        description="simulate: the simulated robot it is on (it picks that robot's parts)",
    )

    def cell(self) -> CellClient | None:
        return CellClient(self.mounted_on) if self.simulate and self.mounted_on else None

    def default_name(self) -> str:
        return "sim-gripper" if self.simulate else "gripper"


def _robotiq(identity: DeviceIdentity, options: ModbusGripperOptions) -> RobotiqGripper:
    profile = robotiq.PROFILES[options.profile]
    unit_id = options.unit_id if options.unit_id is not None else robotiq.UNIT_ID
    simulator = None
    address = options.link_address()
    if options.simulate:
        simulator = RobotiqSimulator(profile, "127.0.0.1", cell=options.cell())
        address = simulator.address
    link = ModbusLink(address, unit_id, options.timeout)
    return RobotiqGripper(
        identity.model_copy(update={"model": profile.model}),
        profile,
        link,
        poll_hz=options.poll_hz,
        simulator=simulator,
    )


def _digital(identity: DeviceIdentity, options: ModbusGripperOptions) -> DigitalGripper:
    registers = load_gripper_map(options.map or DIGITAL_MAP)
    if options.unit_id is not None:
        registers = registers.model_copy(update={"unit_id": options.unit_id})
    simulator = None
    address = options.link_address()
    if options.simulate:
        simulator = DigitalGripperSimulator(
            registers,
            registers.stroke,
            registers.move_time,
            host="127.0.0.1",
            cell=options.cell(),
        )
        address = simulator.address
    link = ModbusLink(address, registers.unit_id, options.timeout)
    block = ModbusIODriver(
        identity.model_copy(update={"kind": "io"}),
        registers,
        link,
        poll_hz=options.poll_hz,
        simulator=simulator,
    )
    return DigitalGripper(
        identity.model_copy(update={"model": registers.model[:64]}), block, registers
    )


def create(name: str, uuid: str, options: ModbusGripperOptions) -> GripperDriver:
    identity = DeviceIdentity(uuid=uuid, kind="gripper", model="", name=name)
    if options.profile == "digital":
        return _digital(identity, options)
    return _robotiq(identity, options)


class ObjectBetween(BaseModel):
    width: float | None = Field(ge=0, le=1, allow_inf_nan=False)  # m; None: nothing there


def routes(driver: RobotiqGripper | DigitalGripper) -> APIRouter:
    """A simulated gripper's world: put an object of some width between its fingers (as a
    part on the table would be), or take it away."""
    router = APIRouter(prefix="/sim")
    simulator = driver.simulator
    if not isinstance(simulator, RobotiqSimulator | DigitalGripperSimulator):
        return router
    jaws = simulator.jaws

    @router.put("/object")
    async def place_object(body: ObjectBetween) -> GripperState:
        jaws.place(body.width)
        return driver.state()

    @router.get("/fingers")
    async def fingers() -> dict[str, float | bool | None]:
        at = jaws.at()
        return {"width": at.width, "moving": at.moving, "object_width": jaws.object_width}

    return router
