"""Modbus round trips on loopback: an output written and confirmed by its read-back (what a
program's `set output` waits for), and a poll of every signal of the default cell's I/O
block, through the Modbus I/O driver against a simulated block on pymodbus's server."""

from __future__ import annotations

import asyncio
import time

from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.link import ModbusLink
from openpendant.device_drivers.modbus_io.registers import load_map
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.paths import MODBUS_MAPS_DIR

FIGURES = ("modbus_roundtrip_p50", "modbus_roundtrip_p99", "modbus_poll_p99")


async def _measure(count: int) -> tuple[list[float], list[float]]:
    registers = load_map(MODBUS_MAPS_DIR / "cell_io.yaml")
    sim = ModbusSimulator(registers)
    await sim.start()
    identity = DeviceIdentity(uuid="bench-io", kind="io", model="bench", name="bench-io")
    driver = ModbusIODriver(identity, registers, ModbusLink(sim.address, registers.unit_id, 1.0))
    writes: list[float] = []
    polls: list[float] = []
    try:
        await driver.poll_once()  # connected
        for i in range(count):
            t0 = time.perf_counter()
            await driver.write("out3", SignalWrite(value=i % 2 == 0))
            writes.append((time.perf_counter() - t0) * 1000)
            t0 = time.perf_counter()
            await driver.poll_once()
            polls.append((time.perf_counter() - t0) * 1000)
    finally:
        await driver.shutdown()
        await sim.stop()
    return writes, polls


def run() -> list[Figure]:
    count = 100 if quick() else 1000
    writes, polls = asyncio.run(_measure(count))
    details = {"samples": count, "path": "driver → pymodbus server on loopback, one connection"}
    return [
        Figure("modbus_roundtrip_p50", percentile(writes, 50), "ms", details=details),
        Figure("modbus_roundtrip_p99", percentile(writes, 99), "ms", details=details),
        Figure(
            "modbus_poll_p99",
            percentile(polls, 99),
            "ms",
            details={**details, "reads": "coils, discrete inputs, input and holding registers"},
        ),
    ]
