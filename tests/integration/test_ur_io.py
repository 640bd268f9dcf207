"""A UR controller's I/O through the standard I/O interface (issue 16: "digital/analog/tool
I/O through the I/O interface"): the ur-io driver, ur-rtde underneath, against the
controller emulator. Every bank read, outputs written and confirmed by the controller's own
state, bad writes refused with nothing written, and a lost controller making every signal
unknown until it is back."""

from __future__ import annotations

import asyncio
import subprocess
import time
from collections.abc import Awaitable, Callable, Iterator
from typing import Any

import pytest
import rtde_io

from openpendant.device_drivers.ur_rtde.emulator import control as emulator_control
from openpendant.device_drivers.ur_rtde.io_driver import URIODriver
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.kit.errors import InvalidValue, NotFound, OpenPendantError

HOST = "127.0.0.6"


def world(command: str) -> None:
    assert emulator_control.world(HOST, command) == "ok", command


def emulated() -> dict[str, Any]:
    return emulator_control.emulated(HOST)


@pytest.fixture(scope="module")
def emulator() -> Iterator[subprocess.Popen[str]]:
    proc = emulator_control.start(HOST)
    yield proc
    if proc.poll() is None:
        emulator_control.stop(proc)


async def until(check: Callable[[], bool], what: str, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"{what}: not within {timeout} s"
        await asyncio.sleep(0.01)


def driven(work: Callable[[URIODriver], Awaitable[None]], **options: Any) -> None:
    """`work(driver)` with a connected ur-io driver on a loop of its own."""

    async def run() -> None:
        identity = DeviceIdentity(uuid="ur-io-1", kind="io", model="UR I/O", name="ur_io")
        driver = URIODriver(identity, HOST, **options)
        await driver.start()
        try:
            await until(lambda: driver.state().connected, "connected")
            await work(driver)
        finally:
            await driver.shutdown()

    asyncio.run(run())


def test_every_bank_of_inputs_is_read_by_its_polyscope_name(
    emulator: subprocess.Popen[str],
) -> None:
    async def work(driver: URIODriver) -> None:
        names = [s.name for s in driver.info.signals]
        assert names[:3] == ["di0", "di1", "di2"] and "ci7" in names and "ti1" in names
        assert {"do7", "co0", "to1", "ai0", "ai1", "ao0", "ao1"} <= set(names)
        assert {s.unit for s in driver.info.signals if s.name.startswith("a")} == {"V"}
        # standard 3, configurable 2 (bit 10), tool 1 (bit 17); 2.5 V on AI1
        for bit in (3, 10, 17):
            world(f"digital input {bit} on")
        world("analog input 1 2.5")
        await until(
            lambda: all(driver.state().values[n] for n in ("di3", "ci2", "ti1")), "inputs seen"
        )
        values = driver.state().values
        assert not values["di2"] and not values["ci3"] and not values["ti0"]
        await until(lambda: driver.state().values["ai1"] == pytest.approx(2.5), "AI1 seen")
        reading = await driver.read("ci2")
        assert reading.value is True
        for bit in (3, 10, 17):
            world(f"digital input {bit} off")
        await until(lambda: driver.state().values["di3"] is False, "DI3 off seen")
        changed = driver.state().changed
        assert changed["di3"] > changed["di0"]  # when each last changed, for a missed state

    driven(work)


def test_outputs_are_written_and_confirmed_by_the_controllers_own_state(
    emulator: subprocess.Popen[str],
) -> None:
    async def work(driver: URIODriver) -> None:
        for name, bit in (("do4", 4), ("co1", 9), ("to0", 16)):
            reading = await driver.write(name, SignalWrite(value=True))
            assert reading.value is True
            assert emulated()["digital_outputs"] >> bit & 1, name
            reading = await driver.write(name, SignalWrite(value=False))
            assert reading.value is False and not emulated()["digital_outputs"] >> bit & 1
        reading = await driver.write("ao0", SignalWrite(value=7.5))
        assert reading.value == pytest.approx(7.5)
        assert emulated()["analog_outputs"][0] == pytest.approx(7.5)
        assert driver.state().values["ao0"] == pytest.approx(7.5)

    driven(work)


def test_current_outputs_take_milliamperes(emulator: subprocess.Popen[str]) -> None:
    async def work(driver: URIODriver) -> None:
        ao1 = next(s for s in driver.info.signals if s.name == "ao1")
        assert (ao1.unit, ao1.minimum, ao1.maximum) == ("mA", 4.0, 20.0)
        reading = await driver.write("ao1", SignalWrite(value=12.0))  # half the range
        assert reading.value == pytest.approx(12.0)
        assert emulated()["analog_outputs"][1] == pytest.approx(12.0)

    driven(work, analog_outputs="current")


def test_bad_writes_are_refused_and_change_nothing(emulator: subprocess.Popen[str]) -> None:
    async def work(driver: URIODriver) -> None:
        await driver.write("do1", SignalWrite(value=False))
        await driver.write("ao1", SignalWrite(value=1.0))
        before = emulated()
        for name, value, code in (
            ("di1", True, "read_only"),
            ("ai0", 1.0, "read_only"),
            ("do1", 1.0, "invalid_value"),
            ("ao1", True, "invalid_value"),
            ("ao1", 10.5, "invalid_value"),
            ("ao1", -0.1, "invalid_value"),
            ("ao1", float("nan"), "invalid_value"),
        ):
            with pytest.raises(InvalidValue) as refused:  # NaN: past the model's own check
                await driver.write(name, SignalWrite.model_construct(value=value))
            assert refused.value.code == code, (name, value)
        with pytest.raises(NotFound):
            await driver.write("do8", SignalWrite(value=True))
        with pytest.raises(NotFound):
            await driver.read("lamp")
        after = emulated()
        assert after["digital_outputs"] == before["digital_outputs"]
        assert after["analog_outputs"] == before["analog_outputs"]

    driven(work)


def test_a_write_waits_while_another_connection_holds_the_outputs(
    emulator: subprocess.Popen[str],
) -> None:
    """A controller gives each RTDE input field to one connection at a time: a write that
    finds the outputs held (the arm's driver writing its tool output that moment) is tried
    again until they are free; held for longer, it is refused and nothing is written."""

    async def work(driver: URIODriver) -> None:
        holder = await asyncio.to_thread(rtde_io.RTDEIOInterface, HOST)
        asyncio.get_running_loop().call_later(0.5, holder.disconnect)
        started = time.monotonic()
        reading = await driver.write("do5", SignalWrite(value=True))
        assert reading.value is True
        assert time.monotonic() - started > 0.4  # it waited for the holder
        await driver.write("do6", SignalWrite(value=False))
        holder = await asyncio.to_thread(rtde_io.RTDEIOInterface, HOST)
        try:
            with pytest.raises(OpenPendantError) as refused:
                await driver.write("do6", SignalWrite(value=True))
            assert refused.value.code == "outputs_in_use", refused.value.message
        finally:
            holder.disconnect()
        assert not emulated()["digital_outputs"] >> 6 & 1

    driven(work)


def test_a_lost_controller_makes_every_signal_unknown_until_it_is_back(
    emulator: subprocess.Popen[str],
) -> None:
    async def work(driver: URIODriver) -> None:
        world("digital input 0 on")
        await until(lambda: driver.state().values["di0"] is True, "DI0 seen")
        emulator_control.stop(emulator)
        await until(lambda: not driver.state().connected, "the loss seen")
        state = driver.state()
        assert set(state.values.values()) == {None} and f"controller at {HOST}" in state.error
        with pytest.raises(OpenPendantError) as refused:
            await driver.write("do0", SignalWrite(value=True))
        assert refused.value.code == "disconnected"
        with pytest.raises(OpenPendantError):
            await driver.read("di0")
        restarted = emulator_control.start(HOST)
        try:
            # A new controller: its inputs are off; what the driver knew before is not shown.
            await until(lambda: driver.state().connected, "reconnected", timeout=15.0)
            assert driver.state().values["di0"] is False and driver.state().error == ""
            assert not emulated()["digital_outputs"] & 1  # the refused write never went out
        finally:
            emulator_control.stop(restarted)

    driven(work)
