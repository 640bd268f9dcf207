"""The connection to one Modbus device, over TCP or a serial line (RTU), shared by the I/O
block and the grippers: one request at a time (many devices and gateways mishandle
interleaved requests, and an RTU line carries one anyway), every refusal or silence turned
into a clear error."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any, Literal

from pymodbus import FramerType
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from openpendant.device_drivers.modbus_io.errors import no_answer, refused
from openpendant.runtime.kit.errors import InvalidValue

Table = Literal["coil", "discrete_input", "input_register", "holding_register"]
Parity = Literal["N", "E", "O"]


@dataclass(frozen=True)
class Address:
    """Where the device is: `host`:`port` over TCP, or `serial` (a port such as /dev/ttyUSB0,
    or a pyserial URL such as socket://host:port) with RTU framing."""

    host: str = "127.0.0.1"
    port: int = 502
    serial: str = ""
    baudrate: int = 115200
    parity: Parity = "N"
    stopbits: int = 1

    @property
    def rtu(self) -> bool:
        return bool(self.serial)

    def __str__(self) -> str:
        return f"{self.serial} (RTU)" if self.rtu else f"{self.host}:{self.port}"


def tcp_address(text: str) -> Address:
    """host:port as a user writes it ([::1]:502 for IPv6)."""
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InvalidValue(f"a Modbus TCP address is host:port, not {text!r}")
    return Address(host=host.strip("[]"), port=int(port))


Client = AsyncModbusTcpClient | AsyncModbusSerialClient


class ModbusLink:
    def __init__(self, address: Address, unit_id: int, timeout: float) -> None:
        self.address, self.unit_id, self.timeout = address, unit_id, timeout
        self._client: Client | None = None  # made on the loop that uses it
        self.lock = asyncio.Lock()  # held for a whole exchange (a write and its read-back)

    @property
    def client(self) -> Client:
        if self._client is None:
            a = self.address
            if a.rtu:
                self._client = AsyncModbusSerialClient(
                    a.serial,
                    framer=FramerType.RTU,
                    baudrate=a.baudrate,
                    parity=a.parity,
                    stopbits=a.stopbits,
                    timeout=self.timeout,
                    retries=0,
                    reconnect_delay=0,
                )
            else:
                self._client = AsyncModbusTcpClient(
                    a.host, port=a.port, timeout=self.timeout, retries=0, reconnect_delay=0
                )
        return self._client

    async def _connected(self) -> Client:
        client = self.client
        if not client.connected and not await client.connect():
            raise no_answer("connecting", f"nothing answers at {self.address}")
        return client

    async def request(self, what: str, function: str, *args: Any, **kwargs: Any) -> Any:
        """One request by the client method's name, its exception or silence as an error."""
        client = await self._connected()
        try:
            response = await getattr(client, function)(*args, device_id=self.unit_id, **kwargs)
        except (TimeoutError, ModbusException, OSError) as exc:
            client.close()  # a late answer must not be taken for the next request's
            raise no_answer(what, type(exc).__name__) from exc
        if response.isError():
            raise refused(int(getattr(response, "exception_code", 0)), what)
        return response

    async def read(self, table: Table, first: int, count: int) -> list[int]:
        """`count` values from `first`: register words, or 0/1 for coils and inputs."""
        what = f"reading {count} {table.replace('_', ' ')}s from {first}"
        response = await self.request(what, READS[table], first, count=count)
        if table in ("coil", "discrete_input"):
            data = [int(bool(b)) for b in response.bits[:count]]
        else:
            data = list(response.registers)
        if len(data) != count:
            raise no_answer(what, f"{len(data)} values for {count}")
        return data

    async def write_registers(self, what: str, address: int, words: list[int]) -> None:
        await self.request(what, "write_registers", address, words)

    async def write_coil(self, what: str, address: int, value: bool) -> None:
        await self.request(what, "write_coil", address, value)

    def close(self) -> None:
        if self._client is not None:
            self._client.close()


READS: dict[Table, str] = {
    "coil": "read_coils",
    "discrete_input": "read_discrete_inputs",
    "holding_register": "read_holding_registers",
    "input_register": "read_input_registers",
}


async def poll_forever(period: float, once: Callable[[], Awaitable[None]]) -> None:
    """`once` every `period` seconds; after a slow round (a timeout) start again from now
    rather than catching up in a burst."""
    next_at = time.monotonic()
    while True:
        await once()
        next_at += period
        delay = next_at - time.monotonic()
        if delay < 0:
            next_at, delay = time.monotonic(), 0.0
        await asyncio.sleep(delay)
