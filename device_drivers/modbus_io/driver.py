"""An I/O block over Modbus (TCP or RTU): every signal of the register map polled at a
steady rate, outputs written and confirmed by reading them back. One request at a time per
device (see link.py), so concurrent writers queue.

When the device does not answer, every signal is unknown (None) until it does: a value read
before the silence is not shown as if it were still true."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

from openpendant.device_drivers.modbus_io.codec import decode, encode, to_raw, to_unit
from openpendant.device_drivers.modbus_io.link import ModbusLink, Table
from openpendant.device_drivers.modbus_io.polled import Polled
from openpendant.device_drivers.modbus_io.registers import Register, RegisterMap
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import (
    IODriver,
    IOInfo,
    SignalReading,
    SignalRecord,
    SignalValue,
    SignalWrite,
)
from openpendant.runtime.kit.errors import InvalidValue, NotFound, OpenPendantError

log = logging.getLogger(__name__)

Words = dict[tuple[Table, int], int]  # (table, address) -> register word or bit (0/1)


class ModbusIODriver(Polled, SignalRecord, IODriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        registers: RegisterMap,
        link: ModbusLink,
        *,
        poll_hz: float = 20.0,
        clock: Callable[[], float] = time.time,
        simulator: ModbusSimulator | None = None,
    ) -> None:
        info = IOInfo(model=registers.model, signals=[r.signal() for r in registers.signals])
        super().__init__(identity, info)
        self.map = registers
        self.period = 1.0 / poll_hz
        self.link = link
        self._start_record((r.name for r in registers.signals), clock)
        # A simulated device this driver serves itself (`--simulate`), started first.
        self.simulator = simulator

    # The device ---------------------------------------------------------------------------

    async def _read_block(self, table: Table, first: int, count: int) -> Words:
        data = await self.link.read(table, first, count)
        return {(table, first + i): v for i, v in enumerate(data)}

    def _value(self, reg: Register, words: Words) -> SignalValue:
        raw = [words[(reg.table, reg.address + i)] for i in range(reg.words)]
        if reg.type == "bool":
            return bool(raw[0])
        number = decode(raw, reg.data_type, self.map.byte_order, self.map.word_order)
        return to_unit(number, reg.scale, reg.offset)

    def _unknown(self, exc: OpenPendantError) -> None:
        """Every signal unknown, with why: never the last values as if they still held."""
        silent = exc.code in ("device_timeout",)
        self._record(dict.fromkeys(self.values), connected=not silent, error=str(exc))

    # Polling ------------------------------------------------------------------------------

    async def poll_once(self) -> None:
        try:
            async with self.link.lock:
                words: Words = {}
                for table, first, count in self.map.blocks():
                    words.update(await self._read_block(table, first, count))
        except OpenPendantError as exc:
            if exc.message != self.error:
                log.warning("%s: %s", self.identity.name, exc.message)
            self._unknown(exc)
            return
        self._record(
            {r.name: self._value(r, words) for r in self.map.signals}, connected=True, error=""
        )

    # The I/O interface --------------------------------------------------------------------

    def _register(self, name: str) -> Register:
        try:
            return self.map.named(name)
        except KeyError:
            raise NotFound(f"no signal {name!r}", code="unknown_signal") from None

    async def _read_signal(self, reg: Register) -> SignalValue:
        words = await self._read_block(reg.table, reg.address, reg.words)
        value = self._value(reg, words)
        self._record({reg.name: value}, connected=True, error=self.error)
        return value

    async def read(self, name: str) -> SignalReading:
        reg = self._register(name)
        async with self.link.lock:
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
        async with self.link.lock:
            what = f"writing {name}"
            if reg.table == "coil":
                await self.link.write_coil(what, reg.address, bool(words[0]))
            else:
                await self.link.write_registers(what, reg.address, words)
            # Confirmed only by what the device then holds.
            held = await self._read_block(reg.table, reg.address, reg.words)
            value = self._value(reg, held)
            self._record({name: value}, connected=True, error=self.error)
        if [held[(reg.table, reg.address + i)] for i in range(reg.words)] != words:
            raise OpenPendantError(
                f"{name}: wrote {command.value}, the device holds {value}",
                code="not_confirmed",
                status=502,
            )
        return SignalReading(name=name, value=value, ts=self.clock())
