"""The Modbus I/O block as the driver host starts it (`openpendant driver modbus-io`):
against a device at `--address` (TCP) or on `--serial` (RTU), or, with `--simulate`,
against a simulated device this process serves on pymodbus's server (the protocol between
them is the real one)."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.link import Address, ModbusLink, Parity, tcp_address
from openpendant.device_drivers.modbus_io.registers import load_map
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.device_drivers.sim_cell.link import CellClient
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import IOState, SignalWrite
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.paths import MODBUS_MAPS_DIR

DEFAULT_MAP = MODBUS_MAPS_DIR / "cell_io.yaml"


class LinkOptions(BaseModel):
    """Where the device is and how to talk to it, for every Modbus driver."""

    model_config = ConfigDict(extra="forbid")

    address: str = Field(default="127.0.0.1:502", description="the device's host:port (Modbus TCP)")
    serial: str = Field(
        default="", max_length=200, description="a serial port for Modbus RTU (instead of TCP)"
    )
    baudrate: int = Field(default=115200, ge=300, le=4_000_000, description="RTU: bits per second")
    parity: Parity = Field(default="N", description="RTU: N, E or O")
    stopbits: int = Field(default=1, ge=1, le=2, description="RTU: stop bits")
    unit_id: int | None = Field(default=None, ge=0, le=247, description="unit id (default: map's)")
    poll_hz: float = Field(default=20.0, gt=0, le=200, description="polls per second")
    timeout: float = Field(default=1.0, gt=0, le=30, description="seconds to wait for answers")
    simulate: bool = Field(default=False, description="serve a simulated device and use it")

    def link_address(self) -> Address:
        if self.serial:
            return Address(
                serial=self.serial,
                baudrate=self.baudrate,
                parity=self.parity,
                stopbits=self.stopbits,
            )
        return tcp_address(self.address)


class ModbusIOOptions(LinkOptions):
    map: Path | None = Field(default=None, description="register map YAML (default: cell I/O)")
    cell: str = Field(
        default="",
        max_length=64,
        description="simulate: the simulated robot whose cell's sensors set inputs of their names",
    )

    def default_name(self) -> str:
        return "sim-io" if self.simulate else "io"


def create(name: str, uuid: str, options: ModbusIOOptions) -> ModbusIODriver:
    registers = load_map(options.map or DEFAULT_MAP)
    if options.unit_id is not None:
        registers = registers.model_copy(update={"unit_id": options.unit_id})
    simulator = None
    address = options.link_address()
    if options.simulate:
        cell = CellClient(options.cell) if options.cell else None
        simulator = ModbusSimulator(registers, "127.0.0.1", cell=cell)
        address = simulator.address
    identity = DeviceIdentity(uuid=uuid, kind="io", model=registers.model[:64], name=name)
    link = ModbusLink(address, registers.unit_id, options.timeout)
    return ModbusIODriver(identity, registers, link, poll_hz=options.poll_hz, simulator=simulator)


def routes(driver: ModbusIODriver) -> APIRouter:
    """A simulated device's own side: inputs set as a sensor would, outputs read as a
    lamp would show them (tests, demonstrations, the simulated cell)."""
    router = APIRouter(prefix="/sim")
    simulator = driver.simulator
    if simulator is None:
        return router

    @router.put("/signals/{name}")
    async def set_signal(name: str, body: SignalWrite) -> IOState:
        try:
            simulator.set(name, body.value)
        except KeyError:
            raise NotFound(f"no signal {name!r}", code="unknown_signal") from None
        except ValueError as exc:
            raise InvalidValue(f"{name}: {exc}") from exc
        return driver.state()

    @router.get("/signals/{name}")
    async def get_signal(name: str) -> dict[str, bool | float]:
        try:
            return {"value": simulator.get(name)}
        except KeyError:
            raise NotFound(f"no signal {name!r}", code="unknown_signal") from None

    return router
