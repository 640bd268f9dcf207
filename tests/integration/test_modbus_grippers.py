"""The Modbus grippers against simulated ones on pymodbus's own server: a Robotiq 2F-85 /
2F-140 over its register protocol (TCP, and RTU framing as on its own cable), and a gripper
on a block's digital outputs and inputs. Activation, close on a part (it stops there and
says it holds it), open, move to a width, speed and force as the bytes the gripper takes,
refusals before activation, faults, silence (unknown, never the last position) and STOP."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

import pytest

from openpendant.device_drivers.modbus_io import robotiq
from openpendant.device_drivers.modbus_io.digital_gripper import DigitalGripper, load_gripper_map
from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.gripper_entry import DIGITAL_MAP
from openpendant.device_drivers.modbus_io.link import ModbusLink
from openpendant.device_drivers.modbus_io.robotiq import Request
from openpendant.device_drivers.modbus_io.robotiq_gripper import GripperFault, RobotiqGripper
from openpendant.device_drivers.modbus_io.sim_grippers import (
    DigitalGripperSimulator,
    RobotiqSimulator,
)
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.gripper import GripperMotion
from openpendant.runtime.kit.errors import InvalidValue
from tests.integration.test_modbus_io import until

pytestmark = pytest.mark.concurrent  # no runtime, no robot: nothing here is real-time

IDENTITY = DeviceIdentity(uuid="g-1", kind="gripper", model="", name="gripper")


def run_robotiq(
    test: Callable[[RobotiqSimulator, RobotiqGripper], Awaitable[None]],
    profile: str = "robotiq-2f-85",
    *,
    rtu: bool = False,
    timeout: float = 0.5,
) -> None:
    async def main() -> None:
        sim = RobotiqSimulator(robotiq.PROFILES[profile], rtu=rtu)
        await sim.start()
        link = ModbusLink(sim.address, robotiq.UNIT_ID, timeout)
        gripper = RobotiqGripper(IDENTITY, robotiq.PROFILES[profile], link)
        try:
            await test(sim, gripper)
        finally:
            await gripper.shutdown()
            await sim.stop()

    asyncio.run(main())


def test_the_register_bytes_are_the_manuals() -> None:
    # Robotiq's examples: "close at full speed and force" is 09 00 | 00 FF | FF FF, and a
    # status of B9 00 | 00 FF | BD 00 is "activated, going, stopped on an object while
    # closing, at count 189".
    assert Request(robotiq.ACT | robotiq.GTO, 255, 255, 255).words() == [0x0900, 0x00FF, 0xFFFF]
    status = robotiq.Status.of([0xB900, 0x00FF, 0xBD00])
    assert status.activated and status.going and status.activation == robotiq.ACTIVE
    assert status.object == robotiq.STOPPED_CLOSING and status.echo == 255
    assert status.position == 189 and status.fault == 0
    assert robotiq.Status.of(status.words()) == status
    assert robotiq.Status.of([0x3100, 0, 0]).activation == robotiq.ACTIVE  # 31: activated
    assert robotiq.scaled(235.0, (20.0, 235.0)) == 255
    assert robotiq.scaled(1e6, (20.0, 235.0)) == 255 and robotiq.scaled(0, (20.0, 235.0)) == 0


@pytest.mark.parametrize("rtu", [False, True])
def test_activate_close_on_a_part_open_and_move(rtu: bool) -> None:
    async def test(sim: RobotiqSimulator, gripper: RobotiqGripper) -> None:
        with pytest.raises(InvalidValue) as refused:
            await gripper.close(GripperMotion())
        assert refused.value.code == "not_activated"
        state = await gripper.activate()
        assert state.activated and state.fault == ""
        sim.jaws.place(0.030)  # a 30 mm part between the fingers
        state = await gripper.close(GripperMotion(force=100.0, speed=0.15))
        assert state.object_detected and not state.moving
        assert state.position == pytest.approx(0.030, abs=0.001)  # one count is 0.33 mm
        sent = Request.of(sim.data["holding_register"][1000:1003])
        assert sent.position == 255 and sent.speed == 255
        assert sent.force == robotiq.scaled(100.0, (20.0, 235.0))
        state = await gripper.open(GripperMotion())
        assert not state.object_detected and state.position == pytest.approx(0.085)
        sim.jaws.place(None)
        state = await gripper.move(GripperMotion(position=0.040, speed=0.05))
        assert state.position == pytest.approx(0.040, abs=0.001) and not state.object_detected
        assert sim.jaws.at().width == pytest.approx(0.040, abs=0.001)
        with pytest.raises(InvalidValue):
            await gripper.move(GripperMotion(position=0.2))
        with pytest.raises(InvalidValue):
            await gripper.move(GripperMotion())

    run_robotiq(test, rtu=rtu)


def test_a_2f_140_has_its_own_stroke_and_force_range() -> None:
    async def test(sim: RobotiqSimulator, gripper: RobotiqGripper) -> None:
        assert gripper.info.stroke == 0.140 and gripper.info.max_force == 125.0
        await gripper.activate()
        await gripper.close(GripperMotion(force=125.0))
        assert Request.of(sim.data["holding_register"][1000:1003]).force == 255
        state = await gripper.open(GripperMotion())
        assert state.position == pytest.approx(0.140)

    run_robotiq(test, "robotiq-2f-140")


def test_a_fault_is_reported_in_words_and_ends_the_motion() -> None:
    async def test(sim: RobotiqSimulator, gripper: RobotiqGripper) -> None:
        await gripper.activate()
        sim.fault = 0x0E  # overcurrent: the gripper stops until activated again
        with pytest.raises(GripperFault) as fault:
            await gripper.close(GripperMotion())
        assert "overcurrent" in fault.value.message
        await gripper.poll_once()
        assert "overcurrent" in gripper.state().fault
        state = await gripper.activate()  # activation clears it
        assert state.fault == "" and state.activated

    run_robotiq(test)


def test_a_silent_gripper_is_unknown_never_its_last_position() -> None:
    async def test(sim: RobotiqSimulator, gripper: RobotiqGripper) -> None:
        await gripper.activate()
        await gripper.poll_once()
        assert gripper.state().position == pytest.approx(0.085)
        sim.silent.set()
        await gripper.poll_once()
        state = gripper.state()
        assert not state.connected and state.position is None and not state.object_detected
        assert "did not answer" in state.fault

    run_robotiq(test, timeout=0.3)


def test_stop_halts_the_fingers_where_they_are() -> None:
    async def test(sim: RobotiqSimulator, gripper: RobotiqGripper) -> None:
        await gripper.activate()
        closing = asyncio.create_task(gripper.close(GripperMotion(speed=0.02)))  # 4 s to close
        await until(lambda: sim.jaws.at().width < 0.080)
        await gripper.stop()
        state = await closing  # the close ends: the fingers stopped
        width = sim.jaws.at().width
        assert 0.010 < width < 0.080 and not sim.jaws.at().moving
        assert state.position == pytest.approx(width, abs=0.001)

    run_robotiq(test)


def run_digital(test: Callable[[DigitalGripperSimulator, DigitalGripper], Awaitable[None]]) -> None:
    registers = load_gripper_map(DIGITAL_MAP)

    async def main() -> None:
        # Its port is found when it listens: the block points the link at it then.
        sim = DigitalGripperSimulator(registers, registers.stroke, registers.move_time)
        link = ModbusLink(sim.address, registers.unit_id, 0.5)
        block = ModbusIODriver(
            IDENTITY.model_copy(update={"kind": "io"}), registers, link, simulator=sim
        )
        gripper = DigitalGripper(IDENTITY, block, registers)
        await gripper.start()
        try:
            await test(sim, gripper)
        finally:
            await gripper.shutdown()

    asyncio.run(main())


def test_a_gripper_on_two_valves_closes_on_a_part_and_opens() -> None:
    async def test(sim: DigitalGripperSimulator, gripper: DigitalGripper) -> None:
        assert gripper.info.capabilities == ["object_detection"]
        sim.jaws.place(0.020)
        state = await gripper.close(GripperMotion())
        assert sim.get("close") is True and sim.get("open") is False
        assert state.object_detected and state.connected
        state = await gripper.open(GripperMotion())
        assert sim.get("close") is False and sim.get("open") is True
        assert not state.object_detected and state.position == pytest.approx(0.04)
        sim.jaws.place(None)
        state = await gripper.close(GripperMotion())  # nothing to grip: closed, empty
        assert not state.object_detected
        with pytest.raises(InvalidValue) as refused:
            await gripper.move(GripperMotion(position=0.01))
        assert refused.value.code == "not_supported"
        # STOP leaves the valves: a part it holds is not dropped.
        await gripper.stop()
        assert sim.get("close") is True

    run_digital(test)
