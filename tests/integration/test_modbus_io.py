"""The Modbus I/O driver against a device on pymodbus's own server, over TCP on loopback
(and RTU framing through pyserial's socket:// as a serial line would carry it): every data
type in every byte and word order, scaling, every exception code, a silent device (its
signals become unknown), a device restarted (the driver reconnects), 20 writers at once
(one request at a time, each write confirmed by its read-back) and a shutdown mid-poll.
The block in a running runtime is in test_modbus_runtime.py."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Awaitable, Callable
from typing import Any

import pytest

from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.entry import ModbusIOOptions, create
from openpendant.device_drivers.modbus_io.errors import EXCEPTIONS, ModbusRefused
from openpendant.device_drivers.modbus_io.link import ModbusLink
from openpendant.device_drivers.modbus_io.registers import RegisterMap
from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator
from openpendant.runtime.drivers.host import build_driver_app
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.kit.errors import InvalidValue, Unavailable

pytestmark = pytest.mark.concurrent  # no runtime, no robot: nothing here is real-time

SIGNALS: list[dict[str, Any]] = [
    {"name": "part_present", "table": "discrete_input", "address": 3},
    {"name": "lamp", "table": "coil", "address": 7},
    {"name": "counts", "table": "input_register", "address": 0, "type": "int16"},
    {
        "name": "pressure",
        "table": "input_register",
        "address": 1,
        "type": "uint16",
        "scale": 0.01,
        "unit": "bar",
    },
    {
        "name": "position",
        "table": "input_register",
        "address": 2,
        "type": "int32",
        "scale": 0.001,
        "unit": "mm",
    },
    {"name": "flow", "table": "input_register", "address": 4, "type": "float32", "unit": "l/min"},
    {"name": "setpoint", "table": "holding_register", "address": 10, "type": "uint32"},
    {
        "name": "speed",
        "table": "holding_register",
        "address": 12,
        "type": "float32",
        "minimum": 0,
        "maximum": 100,
        "unit": "%",
    },
    {
        "name": "temperature",
        "table": "holding_register",
        "address": 14,
        "type": "int16",
        "scale": 0.1,
        "offset": -50.0,
        "unit": "°C",
    },
] + [
    {"name": f"out{i}", "table": "holding_register", "address": 100 + i, "type": "uint16"}
    for i in range(20)
]


def make_map(byte_order: str = "big", word_order: str = "big") -> RegisterMap:
    return RegisterMap.model_validate(
        {
            "model": "test block",
            "byte_order": byte_order,
            "word_order": word_order,
            "signals": SIGNALS,
        }
    )


def run(
    test: Callable[[ModbusSimulator, ModbusIODriver], Awaitable[None]],
    registers: RegisterMap | None = None,
    timeout: float = 0.5,
    rtu: bool = False,
) -> None:
    registers = registers or make_map()

    async def main() -> None:
        sim = ModbusSimulator(registers, rtu=rtu)
        await sim.start()
        identity = DeviceIdentity(uuid="io-1", kind="io", model="test block", name="io")
        link = ModbusLink(sim.address, registers.unit_id, timeout)
        driver = ModbusIODriver(identity, registers, link)
        try:
            await test(sim, driver)
        finally:
            await driver.shutdown()
            await sim.stop()

    asyncio.run(main())


@pytest.mark.parametrize(
    ("byte_order", "word_order", "rtu"),
    [(*orders, False) for orders in itertools.product(("big", "little"), repeat=2)]
    + [("big", "little", True)],
)
def test_every_type_scaled_in_every_order(byte_order: str, word_order: str, rtu: bool) -> None:
    inputs = {
        "part_present": True,
        "counts": -1234,
        "pressure": 6.5,
        "position": -70.123,
        "flow": 12.75,
    }
    outputs = {"lamp": True, "setpoint": 70000.0, "speed": 42.5, "temperature": 21.5}

    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        for name, value in inputs.items():
            sim.set(name, value)
        await driver.poll_once()
        assert driver.state().connected and driver.state().error == ""
        for name, value in inputs.items():
            assert driver.values[name] == pytest.approx(value), name
        for name, value in outputs.items():
            written = await driver.write(name, SignalWrite(value=value))
            assert written.value == pytest.approx(value), name
            assert sim.get(name) == pytest.approx(value), name  # what the device holds
        # The coding is the device's: the raw words differ by order, the values do not.
        assert sim.data["input_register"][2:4] != [0, 0]

    run(test, make_map(byte_order, word_order), rtu=rtu)


def test_writes_the_device_cannot_hold_are_refused_before_sending() -> None:
    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        before = len(sim.requests)
        for name, value in (
            ("speed", 100.5),
            ("lamp", 1.0),
            ("temperature", 1e6),
            ("out0", 70000),
            ("out0", True),
        ):
            with pytest.raises(InvalidValue):
                await driver.write(name, SignalWrite(value=value))
        with pytest.raises(InvalidValue) as refused:
            await driver.write("part_present", SignalWrite(value=True))
        assert refused.value.code == "read_only"
        assert len(sim.requests) == before  # nothing reached the device

    run(test)


def test_every_exception_code_is_a_clear_error_and_the_signals_unknown() -> None:
    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        sim.set("part_present", True)
        await driver.poll_once()
        assert driver.values["part_present"] is True
        for code, (name, meaning) in EXCEPTIONS.items():
            sim.fail_with = code
            with pytest.raises(ModbusRefused) as refused:
                await driver.read("pressure")
            assert refused.value.code == f"modbus_{name}"
            assert f"exception {code}" in refused.value.message and meaning in refused.value.message
            with pytest.raises(ModbusRefused):
                await driver.write("lamp", SignalWrite(value=True))
            await driver.poll_once()
            state = driver.state()
            assert set(state.values.values()) == {None}, code
            assert meaning in state.error
        sim.fail_with = None
        await driver.poll_once()
        assert driver.values["part_present"] is True and driver.state().error == ""

    run(test)


def test_a_silent_device_makes_every_signal_unknown_never_the_last_value() -> None:
    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        sim.set("part_present", True)
        sim.set("pressure", 3.0)
        await driver.poll_once()
        assert driver.values["pressure"] == pytest.approx(3.0)
        sim.silent.set()
        await driver.poll_once()
        state = driver.state()
        assert not state.connected and set(state.values.values()) == {None}
        assert "did not answer" in state.error
        assert state.changed["pressure"] >= state.ts - 5  # the change to unknown is a change
        with pytest.raises(Unavailable):
            await driver.read("pressure")

    run(test, timeout=0.3)


def test_a_restarted_device_is_reconnected_to_without_a_restart_of_the_driver() -> None:
    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        sim.set("counts", 7)
        await driver.start()  # polling on its own
        await until(lambda: driver.values["counts"] == 7)
        await sim.stop()
        await until(lambda: driver.values["counts"] is None and not driver.connected)
        sim.set("counts", 8)  # what the device holds when it is back
        await sim.start()
        await until(lambda: driver.values["counts"] == 8 and driver.connected)
        assert driver.state().error == ""

    run(test)


def test_twenty_writers_at_once_go_one_at_a_time_each_confirmed() -> None:
    async def test(sim: ModbusSimulator, driver: ModbusIODriver) -> None:
        await driver.start()  # the poller competes for the device too
        answers = await asyncio.gather(
            *(driver.write(f"out{i}", SignalWrite(value=1000 + i)) for i in range(20))
        )
        assert [a.value for a in answers] == [1000 + i for i in range(20)]
        assert [sim.get(f"out{i}") for i in range(20)] == [1000 + i for i in range(20)]
        # Every write was followed at once by its own read-back: nothing came between.
        log = sim.requests
        writes = [i for i, (fc, _) in enumerate(log) if fc == 16]
        assert len(writes) == 20
        for i in writes:
            assert log[i + 1] == (3, log[i][1]), log[i : i + 2]

    run(test)


async def until(check: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = asyncio.get_running_loop().time() + timeout
    while not check():
        if asyncio.get_running_loop().time() > deadline:
            raise TimeoutError("condition not met")
        await asyncio.sleep(0.02)


def test_the_driver_host_shuts_down_while_a_poll_is_under_way() -> None:
    """`openpendant driver modbus-io --simulate` hung on SIGTERM until it was killed: its
    poll was inside a request when cancelled, and Python 3.11's wait_for (through which
    pymodbus awaits the answer) swallowed the cancel when the answer came in the same loop
    round. The host's shutdown, begun while a request is on its way, now ends, with the
    poll and the state stream ended."""

    async def main() -> None:
        uuid = "3f2b8c1e-0000-4000-8000-00000000000a"
        driver = create("io", uuid, ModbusIOOptions(simulate=True))
        app = build_driver_app(driver, advertisement=None, interfaces=[], state_rate_hz=100)
        lifespan = app.router.lifespan_context(app)
        ending: list[asyncio.Task[Any]] = []
        read = driver.link.read

        async def read_then_shut_down(*args: Any) -> list[int]:
            if driver.seqno >= 5 and not ending:  # a request on its way, the shutdown begun
                ending.append(asyncio.create_task(lifespan.__aexit__(None, None, None)))
            return await read(*args)

        driver.link.read = read_then_shut_down  # type: ignore[method-assign,assignment]
        await lifespan.__aenter__()
        for _ in range(500):
            if ending:
                break
            await asyncio.sleep(0.01)
        done, _ = await asyncio.wait(ending, timeout=10)
        assert done, "the shutdown hangs"
        assert driver._poller is not None and driver._poller.done()

    asyncio.run(main())
