"""The UR controller emulator, driven by the unmodified ur-rtde library (the receive, control
and I/O interfaces and the dashboard client, in this process; the emulator in its own):
state streamed at the e-Series rate, the control script uploaded and run, blocking moves,
speedJ and its stop, I/O and the speed slider, a protective stop refusing commands until it
is unlocked, an E-stop and the power-up after it, and the watchdog stopping the program when
its client dies."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import rtde_control
import rtde_io
import rtde_receive
from dashboard_client import DashboardClient

from openpendant.device_drivers.ur_rtde.emulator import control as control_
from openpendant.runtime.bench.harness.processes import wait_for

HOST = "127.0.0.2"  # the emulator's own address: ur-rtde's ports are fixed


def world(command: str) -> str:
    return control_.world(HOST, command)


def emulated() -> dict[str, Any]:
    return control_.emulated(HOST)


@pytest.fixture(scope="module")
def emulator() -> Iterator[subprocess.Popen[str]]:
    proc = control_.start(HOST)
    yield proc
    control_.stop(proc)


@pytest.fixture(scope="module")
def receive(emulator: subprocess.Popen[str]) -> Iterator[rtde_receive.RTDEReceiveInterface]:
    r = rtde_receive.RTDEReceiveInterface(HOST)
    yield r
    r.disconnect()


@pytest.fixture(autouse=True)
def at_rest(emulator: subprocess.Popen[str]) -> None:
    """Each test from a powered, normal robot with no program running."""
    world("reset")


@pytest.fixture
def control(
    emulator: subprocess.Popen[str], receive: rtde_receive.RTDEReceiveInterface
) -> Iterator[rtde_control.RTDEControlInterface]:
    if receive.isProtectiveStopped() or receive.isEmergencyStopped():
        world("estop off")
        dashboard = DashboardClient(HOST)
        dashboard.connect()
        dashboard.unlockProtectiveStop()
        dashboard.powerOn()
        dashboard.brakeRelease()
        dashboard.disconnect()
    c = rtde_control.RTDEControlInterface(HOST)
    yield c
    c.stopScript()
    c.disconnect()


def test_state_streams_at_the_e_series_rate_and_the_script_runs(
    receive: rtde_receive.RTDEReceiveInterface, control: rtde_control.RTDEControlInterface
) -> None:
    assert receive.getRobotMode() == 7 and receive.getSafetyMode() == 1  # running, normal
    assert control.isProgramRunning()
    # The receive interface has a connection of its own: it sees the script start a few
    # packages later (seen 1 = stopped right after the control interface's start).
    wait_for(lambda: receive.getRuntimeState() == 2, 2, what="the receive side sees it run")
    first = receive.getTimestamp()
    wait_for(lambda: receive.getTimestamp() > first + 0.1, 5, what="time going on")
    assert len(receive.getActualQ()) == 6 and len(receive.getActualTCPPose()) == 6
    assert emulated()["scripts"] >= 1


def test_a_blocking_movej_ends_at_its_target(
    receive: rtde_receive.RTDEReceiveInterface, control: rtde_control.RTDEControlInterface
) -> None:
    start = np.array(receive.getActualQ())
    target = start + np.array([0.2, -0.1, 0.1, 0.0, 0.1, -0.2])
    assert control.moveJ(target.tolist(), 1.0, 1.4)  # returns once there
    assert np.abs(np.array(emulated()["q"]) - target).max() < 1e-6
    # The receive interface's own connection may be a package behind the control's.
    wait_for(lambda: np.abs(receive.getActualQd()).max() < 1e-6, 5, what="at rest")
    assert np.abs(np.array(receive.getActualQ()) - target).max() < 1e-6


def test_speedj_moves_and_its_stop_halts(
    receive: rtde_receive.RTDEReceiveInterface, control: rtde_control.RTDEControlInterface
) -> None:
    start = receive.getActualQ()[5]
    assert control.speedJ([0, 0, 0, 0, 0, 0.3], 1.0, 0.0)
    wait_for(lambda: receive.getActualQd()[5] > 0.29, 5, what="joint 6 at speed")
    assert control.speedStop(2.0)
    wait_for(lambda: abs(receive.getActualQd()[5]) < 1e-6, 5, what="stopped")
    assert receive.getActualQ()[5] > start
    assert 9 in emulated()["commands"] and 15 in emulated()["commands"]


def test_outputs_and_the_speed_slider_through_the_io_interface(
    receive: rtde_receive.RTDEReceiveInterface,
) -> None:
    io = rtde_io.RTDEIOInterface(HOST)
    try:
        assert io.setStandardDigitalOut(3, True)
        assert io.setToolDigitalOut(1, True)
        # Two packages, applied one after the other: a state may come between them.
        both = (1 << 3) | (1 << 17)
        wait_for(lambda: receive.getActualDigitalOutputBits() & both == both, 5, what="DO3, TO1")
        assert receive.getActualDigitalOutputBits() == both
        assert io.setStandardDigitalOut(3, False)
        wait_for(lambda: not receive.getDigitalOutState(3), 5, what="DO3 off")
        assert io.setSpeedSlider(0.4)
        wait_for(lambda: abs(receive.getTargetSpeedFraction() - 0.4) < 1e-9, 5, what="slider")
        assert io.setSpeedSlider(1.0)
        world("digital input 2 on")
        wait_for(lambda: receive.getDigitalInState(2), 5, what="DI2 seen")
    finally:
        io.disconnect()


def test_a_protective_stop_refuses_commands_until_it_is_unlocked(
    receive: rtde_receive.RTDEReceiveInterface, control: rtde_control.RTDEControlInterface
) -> None:
    assert control.speedJ([0.2, 0, 0, 0, 0, 0], 1.0, 0.0)
    world("protective stop")
    wait_for(receive.isProtectiveStopped, 5, what="protective stop seen")
    wait_for(lambda: abs(receive.getActualQd()[0]) < 1e-6, 5, what="the arm halted")
    assert not control.isProgramRunning()
    assert not control.moveJ(receive.getActualQ(), 1.0, 1.4)  # refused, not queued
    dashboard = DashboardClient(HOST)
    dashboard.connect()
    try:
        assert "PROTECTIVE_STOP" in dashboard.safetymode()
        dashboard.unlockProtectiveStop()  # raises unless the controller releases it
        dashboard.closeSafetyPopup()
    finally:
        dashboard.disconnect()
    wait_for(lambda: not receive.isProtectiveStopped(), 5, what="released")
    assert control.reuploadScript()
    wait_for(control.isProgramRunning, 5, what="the script running again")
    assert abs(receive.getActualQd()[0]) < 1e-6  # nothing resumed by itself
    target = receive.getActualQ()
    target[0] -= 0.05
    assert control.moveJ(target, 1.0, 1.4)


def test_an_emergency_stop_powers_off_until_power_on_and_brake_release(
    receive: rtde_receive.RTDEReceiveInterface, control: rtde_control.RTDEControlInterface
) -> None:
    world("estop on")
    wait_for(receive.isEmergencyStopped, 5, what="E-stop seen")
    assert receive.getRobotMode() == 3  # power off
    world("estop off")
    dashboard = DashboardClient(HOST)
    dashboard.connect()
    try:
        dashboard.powerOn()
        wait_for(lambda: receive.getRobotMode() == 5, 5, what="idle")
        dashboard.brakeRelease()
        wait_for(lambda: receive.getRobotMode() == 7, 5, what="running")
        assert "RUNNING" in dashboard.robotmode()
    finally:
        dashboard.disconnect()
    assert not control.isProgramRunning()  # the E-stop ended it


WATCHED_CLIENT = f"""
import sys, time, rtde_control
c = rtde_control.RTDEControlInterface({HOST!r})
c.setWatchdog(20.0)
print("moving", flush=True)
while True:  # each speedJ feeds the watchdog (a kick in the same 2 ms would replace it)
    c.speedJ([0.1, 0, 0, 0, 0, 0], 1.0, 0.0)
    time.sleep(0.01)
"""


def test_the_watchdog_stops_the_program_when_its_client_is_killed(
    receive: rtde_receive.RTDEReceiveInterface, emulator: subprocess.Popen[str]
) -> None:
    client = subprocess.Popen(
        [sys.executable, "-c", WATCHED_CLIENT], stdout=subprocess.PIPE, text=True
    )
    try:
        assert client.stdout is not None
        assert client.stdout.readline().strip() == "moving"
        wait_for(lambda: emulated()["qd"][0] > 0.09, 5, what=f"moving ({emulated()})")
        time.sleep(0.3)  # kicked all along: still running
        assert receive.getRuntimeState() == 2
        client.kill()
        client.wait(5)
        wait_for(lambda: receive.getRuntimeState() == 1, 5, what="the program stopped")
        wait_for(lambda: abs(receive.getActualQd()[0]) < 1e-6, 5, what="the arm halted")
    finally:
        client.kill()
        client.wait(5)
