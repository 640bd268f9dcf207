"""A simulated Modbus device on pymodbus's own server (TCP, or RTU framing on a loopback
socket as a serial line carries it), holding the signals of a register map: what the driver
reads and writes goes over the real protocol. A test (or the simulated cell) sets inputs by
name, may make the device answer with an exception code, or fall silent. A subclass that is
a machine (a gripper) reacts to writes and refreshes what a read sees."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from pymodbus import FramerType
from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from openpendant.device_drivers.modbus_io.codec import decode, encode, to_raw, to_unit
from openpendant.device_drivers.modbus_io.link import Address, Table, poll_forever
from openpendant.device_drivers.modbus_io.registers import KIND, RegisterMap
from openpendant.device_drivers.sim_cell.link import CellClient

SENSE_PERIOD = 0.05  # s between looks at the simulated cell's presence sensors
# Function code -> (table, writes)
FUNCTIONS: dict[int, tuple[Table, bool]] = {
    1: ("coil", False),
    2: ("discrete_input", False),
    3: ("holding_register", False),
    4: ("input_register", False),
    5: ("coil", True),
    15: ("coil", True),
    6: ("holding_register", True),
    16: ("holding_register", True),
}


def _size(registers: RegisterMap, table: Table) -> int:
    return max([s.address + s.words for s in registers.signals if s.table == table] or [1])


class ModbusSimulator:
    def __init__(
        self,
        registers: RegisterMap,
        host: str = "127.0.0.1",
        port: int = 0,  # 0: any free port (`address` says which, once started)
        *,
        rtu: bool = False,
        cell: CellClient | None = None,
    ) -> None:
        self.map = registers
        # The simulated cell whose presence sensors drive the inputs of the same names.
        self.cell = cell
        self.host, self.port, self.rtu = host, port, rtu
        # What the device holds, by table: one int per register, one 0/1 per coil or input.
        self.data: dict[Table, list[int]] = {table: [0] * _size(registers, table) for table in KIND}
        self.fail_with: int | None = None  # answer every request with this exception code
        self.silent = asyncio.Event()  # set: the device answers nothing
        self.requests: list[tuple[int, int]] = []  # (function code, address), in order
        self._server: ModbusTcpServer | ModbusSerialServer | None = None
        self._task: asyncio.Task[Any] | None = None
        self._sensing: asyncio.Task[None] | None = None

    def _device(self) -> SimDevice:
        def bits(table: Table) -> list[SimData]:
            return [SimData(0, count=len(self.data[table]), values=False, datatype=DataType.BITS)]

        def words(table: Table) -> list[SimData]:
            return [SimData(0, count=len(self.data[table]), values=0, datatype=DataType.REGISTERS)]

        return SimDevice(
            self.map.unit_id,
            simdata=(
                bits("coil"),
                bits("discrete_input"),
                words("holding_register"),
                words("input_register"),
            ),
            action=self._action,
        )

    async def _action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        current_registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        self.requests.append((function_code, address))
        if self.silent.is_set():
            await asyncio.Event().wait()  # never answers (the client gives up)
        if self.fail_with is not None:
            return ExcCodes(self.fail_with)
        if function_code not in FUNCTIONS:
            return None
        table, writes = FUNCTIONS[function_code]
        held = self.data[table]
        if writes and set_values is not None:
            for i, v in enumerate(set_values):
                held[address + i] = int(v)
            await self._written(table, address)
            return None
        self._reading(table, address)
        bitwise = table in ("coil", "discrete_input")
        for a in range(address, min(address + count, len(held))):
            if bitwise:
                word, bit = divmod(a, 16)
                mask = 1 << bit
                i = word - start_address
                current_registers[i] = (
                    (current_registers[i] | mask) if held[a] else (current_registers[i] & ~mask)
                )
            else:
                current_registers[a - start_address] = held[a]
        return None

    async def _written(self, table: Table, address: int) -> None:
        """After a write from `address` on: what a machine does about it."""

    def _reading(self, table: Table, address: int) -> None:
        """Before a read from `address` on: bring what it holds up to date."""

    # Signals by name ------------------------------------------------------------------------

    def set(self, name: str, value: bool | float) -> None:
        """What the device's own side does: an input changing, an output forced."""
        reg = self.map.named(name)
        if reg.type == "bool":
            words = [int(bool(value))]
        else:
            raw = to_raw(float(value), reg.scale, reg.offset, reg.data_type)
            words = encode(raw, reg.data_type, self.map.byte_order, self.map.word_order)
        self.data[reg.table][reg.address : reg.address + reg.words] = words

    def get(self, name: str) -> bool | float:
        reg = self.map.named(name)
        words = self.data[reg.table][reg.address : reg.address + reg.words]
        if reg.type == "bool":
            return bool(words[0])
        raw = decode(words, reg.data_type, self.map.byte_order, self.map.word_order)
        return to_unit(raw, reg.scale, reg.offset)

    # The server -----------------------------------------------------------------------------

    @property
    def address(self) -> Address:
        """Where a driver finds it: over TCP, or through pyserial's socket:// as a line."""
        if self.rtu:
            return Address(serial=f"socket://{self.host}:{self.port}")
        return Address(self.host, self.port)

    async def start(self) -> None:
        if self.rtu:
            self._server = ModbusSerialServer(
                self._device(), framer=FramerType.RTU, port=f"socket://{self.host}:{self.port}"
            )
        else:
            self._server = ModbusTcpServer(self._device(), address=(self.host, self.port))
        self._task = asyncio.create_task(self._server.serve_forever())
        await asyncio.sleep(0)
        if self.port == 0:  # the port the system gave it: nobody can take it meanwhile
            self.port = await self._bound_port()
        for _ in range(100):  # listening once a connection is accepted
            with contextlib.suppress(OSError):
                _, writer = await asyncio.open_connection(self.host, self.port)
                writer.close()
                if self.cell is not None:
                    self._sensing = asyncio.create_task(poll_forever(SENSE_PERIOD, self._sense))
                return
            await asyncio.sleep(0.02)
        raise RuntimeError(f"the Modbus simulator did not listen on {self.host}:{self.port}")

    async def _bound_port(self) -> int:
        server = self._server
        for _ in range(250):
            sockets = getattr(getattr(server, "transport", None), "sockets", None)
            if sockets:
                return int(sockets[0].getsockname()[1])
            if self._task is not None and self._task.done():
                break  # it could not listen: its exception says why
            await asyncio.sleep(0.01)
        raise RuntimeError(f"the Modbus simulator did not listen on {self.host}")

    async def _sense(self) -> None:
        assert self.cell is not None
        answer = await self.cell.ask("sensed")
        inputs = {s.name for s in self.map.signals if s.table == "discrete_input"}
        for name, seen in ((answer or {}).get("sensors") or {}).items():
            if name in inputs:
                self.set(name, bool(seen))

    async def stop(self) -> None:
        if self._sensing is not None:
            self._sensing.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._sensing
            self._sensing = None
        if self._server is not None:
            await self._server.shutdown()  # type: ignore[no-untyped-call]
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._task
        self._server = self._task = None
