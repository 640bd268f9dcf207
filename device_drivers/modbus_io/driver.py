"""An I/O block over Modbus TCP: every signal of the register map polled at a steady rate,
outputs written and confirmed by reading them back. One request at a time per device (many
devices and gateways mishandle interleaved requests), so concurrent writers queue.

When the device does not answer, every signal is unknown (None) until it does: a value read
before the silence is not shown as if it were still true."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable
from typing import Any

from pymodbus.client import AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from device_drivers.modbus_io.codec import decode, encode, to_raw, to_unit
from device_drivers.modbus_io.errors import no_answer, refused
from device_drivers.modbus_io.registers import Register, RegisterMap, Table
from device_drivers.modbus_io.simulator import ModbusSimulator
from runtime.interfaces.device import DeviceIdentity
from runtime.interfaces.io import (
    IODriver,
    IOInfo,
    IOState,
    SignalReading,
    SignalValue,
    SignalWrite,
)
from runtime.kit.errors import InvalidValue, NotFound, OpenPendantError

log = logging.getLogger(__name__)

Words = dict[tuple[Table, int], int]  # (table, address) -> register word or bit (0/1)


class ModbusIODriver(IODriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        registers: RegisterMap,
        host: str,
        port: int,
        *,
        poll_hz: float = 20.0,
        timeout: float = 1.0,
        clock: Callable[[], float] = time.time,
        simulator: ModbusSimulator | None = None,
    ) -> None:
        info = IOInfo(model=registers.model, signals=[r.signal() for r in registers.signals])
        super().__init__(identity, info)
        self.map = registers
        self.period = 1.0 / poll_hz
        self.clock = clock
        self.host, self.port, self.timeout = host, port, timeout
        self._client: AsyncModbusTcpClient | None = None  # made on the loop that uses it
        self.lock = asyncio.Lock()
        self.values: dict[str, SignalValue] = {r.name: None for r in registers.signals}
        self.changed: dict[str, float] = {}
        self.connected = False
        self.error = "not connected yet"
        self.seqno = 0
        self._poller: asyncio.Task[None] | None = None
        # A simulated device this driver serves itself (`--simulate`), started first.
        self.simulator = simulator

    # The device ---------------------------------------------------------------------------

    @property
    def client(self) -> AsyncModbusTcpClient:
        if self._client is None:
            self._client = AsyncModbusTcpClient(
                self.host, port=self.port, timeout=self.timeout, retries=0, reconnect_delay=0
            )
        return self._client

    async def _ensure_connected(self) -> None:
        if self.client.connected:
            return
        if not await self.client.connect():
            raise no_answer("connecting", "nothing accepts connections at its address")

    async def _request(self, what: str, call: Any, *args: Any, **kwargs: Any) -> Any:
        """One request, its exception or silence turned into a clear error."""
        await self._ensure_connected()
        try:
            response = await call(*args, device_id=self.map.unit_id, **kwargs)
        except (TimeoutError, ModbusException, OSError) as exc:
            self.client.close()  # a late answer must not be taken for the next request's
            raise no_answer(what, type(exc).__name__) from exc
        if response.isError():
            raise refused(int(getattr(response, "exception_code", 0)), what)
        return response

    async def _read_block(self, table: Table, first: int, count: int) -> Words:
        calls = {
            "coil": self.client.read_coils,
            "discrete_input": self.client.read_discrete_inputs,
            "holding_register": self.client.read_holding_registers,
            "input_register": self.client.read_input_registers,
        }
        what = f"reading {count} {table.replace('_', ' ')}s from {first}"
        response = await self._request(what, calls[table], first, count=count)
        if table in ("coil", "discrete_input"):
            data = [int(bool(b)) for b in response.bits[:count]]
        else:
            data = list(response.registers)
        if len(data) != count:
            raise no_answer(what, f"{len(data)} values for {count}")
        return {(table, first + i): v for i, v in enumerate(data)}

    def _value(self, reg: Register, words: Words) -> SignalValue:
        raw = [words[(reg.table, reg.address + i)] for i in range(reg.words)]
        if reg.type == "bool":
            return bool(raw[0])
        number = decode(raw, reg.data_type, self.map.byte_order, self.map.word_order)
        return to_unit(number, reg.scale, reg.offset)

    def _update(self, values: dict[str, SignalValue], *, connected: bool, error: str) -> None:
        now = self.clock()
        for name, value in values.items():
            if name not in self.changed or self.values.get(name) != value:
                self.changed[name] = now
            self.values[name] = value
        self.connected, self.error = connected, error
        self.seqno += 1

    def _unknown(self, exc: OpenPendantError) -> None:
        """Every signal unknown, with why: never the last values as if they still held."""
        silent = exc.code in ("device_timeout",)
        self._update(dict.fromkeys(self.values), connected=not silent, error=str(exc))

    # Polling ------------------------------------------------------------------------------

    async def poll_once(self) -> None:
        try:
            async with self.lock:
                words: Words = {}
                for table, first, count in self.map.blocks():
                    words.update(await self._read_block(table, first, count))
        except OpenPendantError as exc:
            if exc.message != self.error:
                log.warning("%s: %s", self.identity.name, exc.message)
            self._unknown(exc)
            return
        self._update(
            {r.name: self._value(r, words) for r in self.map.signals}, connected=True, error=""
        )

    async def _poll(self) -> None:
        next_at = time.monotonic()
        while True:
            await self.poll_once()
            next_at += self.period
            delay = next_at - time.monotonic()
            if delay < 0:  # fell behind (a timeout): start again from now, no burst
                next_at, delay = time.monotonic(), 0.0
            await asyncio.sleep(delay)

    async def start(self) -> None:
        if self.simulator is not None:
            await self.simulator.start()
        self._poller = asyncio.create_task(self._poll())

    async def shutdown(self) -> None:
        if self._poller is not None:
            self._poller.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._poller
        if self._client is not None:
            self._client.close()
        if self.simulator is not None:
            await self.simulator.stop()

    # The I/O interface --------------------------------------------------------------------

    def state(self) -> IOState:
        return IOState(
            seqno=self.seqno,
            ts=self.clock(),
            connected=self.connected,
            values=dict(self.values),
            changed=dict(self.changed),
            error=self.error,
        )

    def _register(self, name: str) -> Register:
        try:
            return self.map.named(name)
        except KeyError:
            raise NotFound(f"no signal {name!r}", code="unknown_signal") from None

    async def _read_signal(self, reg: Register) -> SignalValue:
        words = await self._read_block(reg.table, reg.address, reg.words)
        value = self._value(reg, words)
        self._update({reg.name: value}, connected=True, error=self.error)
        return value

    async def read(self, name: str) -> SignalReading:
        reg = self._register(name)
        async with self.lock:
            value = await self._read_signal(reg)
        return SignalReading(name=name, value=value, ts=self.clock())

    def _coded(self, reg: Register, value: bool | float) -> list[int]:
        if reg.type == "bool":
            if not isinstance(value, bool):
                raise InvalidValue(f"{reg.name} is digital: write true or false")
            return [int(value)]
        if isinstance(value, bool) or not math.isfinite(value):
            raise InvalidValue(f"{reg.name} is analog: write a finite number")
        if (reg.minimum is not None and value < reg.minimum) or (
            reg.maximum is not None and value > reg.maximum
        ):
            raise InvalidValue(f"{reg.name} takes {reg.minimum} to {reg.maximum} {reg.unit}")
        raw = to_raw(value, reg.scale, reg.offset, reg.data_type)
        try:
            return encode(raw, reg.data_type, self.map.byte_order, self.map.word_order)
        except ValueError as exc:
            raise InvalidValue(f"{reg.name}: {exc}") from exc

    async def write(self, name: str, command: SignalWrite) -> SignalReading:
        reg = self._register(name)
        if reg.table not in ("coil", "holding_register"):
            raise InvalidValue(f"{name} is an input: only outputs are written", code="read_only")
        words = self._coded(reg, command.value)
        async with self.lock:
            what = f"writing {name}"
            if reg.table == "coil":
                await self._request(what, self.client.write_coil, reg.address, bool(words[0]))
            else:
                await self._request(what, self.client.write_registers, reg.address, words)
            # Confirmed only by what the device then holds.
            held = await self._read_block(reg.table, reg.address, reg.words)
            value = self._value(reg, held)
            self._update({name: value}, connected=True, error=self.error)
        if [held[(reg.table, reg.address + i)] for i in range(reg.words)] != words:
            raise OpenPendantError(
                f"{name}: wrote {command.value}, the device holds {value}",
                code="not_confirmed",
                status=502,
            )
        return SignalReading(name=name, value=value, ts=self.clock())
