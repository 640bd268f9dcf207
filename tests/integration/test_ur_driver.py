"""The UR driver (ur-rtde underneath) against the controller emulator (issue 16, must-show
2): the state mapped, a jog that stops when its commands stop, a trajectory executed on its
planned path, a halt, a protective stop becoming a fault until reset, a hung dashboard, a
lost connection coming back with nothing moving (and, in a runtime, a steady fault meanwhile,
not a flapping link), and the watchdog stopping the arm when the driver's process dies."""

from __future__ import annotations

import asyncio
import gc
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openpendant.device_drivers.ur_rtde.driver import URDriver
from openpendant.device_drivers.ur_rtde.emulator import control as emulator_control
from openpendant.device_drivers.ur_rtde.link import PLAYING
from openpendant.runtime.bench.harness.processes import DriverProc, Runtime, stop_all
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    DigitalOutputCommand,
    FreedriveCommand,
    JogJointCommand,
    JointTrajectory,
    OperationalMode,
    ProtectiveStopRequest,
    ToolCommand,
    TrajectoryState,
    TrajectoryWaypoint,
)
from openpendant.runtime.kit.errors import RobotError
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info

HOST = "127.0.0.4"
UR5E = load_robot_info("ur5e")


def world(command: str) -> str:
    return emulator_control.world(HOST, command)


def emulated() -> dict[str, Any]:
    return emulator_control.emulated(HOST)


def start_emulator() -> subprocess.Popen[str]:
    return emulator_control.start(HOST)


def stop_emulator(proc: subprocess.Popen[str]) -> None:
    emulator_control.stop(proc)


def until(check: Callable[[], bool], timeout: float = 10.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"{what}: not within {timeout} s"
        time.sleep(0.01)


class Emulator:
    """The emulator process, started again by a test that stops it."""

    def __init__(self) -> None:
        self.proc = start_emulator()

    def alive(self) -> subprocess.Popen[str]:
        if self.proc.poll() is not None:
            self.proc = start_emulator()
        return self.proc


@pytest.fixture(scope="module")
def running() -> Iterator[Emulator]:
    emulator = Emulator()
    yield emulator
    if emulator.proc.poll() is None:
        stop_emulator(emulator.proc)


@pytest.fixture
def emulator(running: Emulator) -> subprocess.Popen[str]:
    """The emulator, its arm at rest, nothing stopped (each test leaves what it did)."""
    proc = running.alive()
    world("estop off")
    world("reset")
    return proc


class Driven:
    """A driver on its own loop in this thread (its control thread runs beside it)."""

    def __init__(self) -> None:
        # As in the driver's host (runtime/kit/app.py): what is loaded lives on, frozen, so
        # no full collection over this test process's big heap stops the control thread
        # past the RTDE watchdog's 100 ms (seen: a 57 ms collection in a small process).
        gc.collect()
        gc.freeze()
        identity = DeviceIdentity(uuid="ur-1", kind="robot", model=UR5E.model, name="ur")
        self.driver = URDriver(identity, UR5E, HOST)
        self.loop = asyncio.new_event_loop()
        self.run(self.driver.start())

    def run(self, work: Any) -> Any:
        return self.loop.run_until_complete(work)

    def close(self) -> None:
        self.run(self.driver.shutdown())
        self.loop.close()

    def ready(self) -> None:
        until(lambda: not self.driver.state().flags.communication_failure, what="connected")
        if self.driver.state().flags.error:
            self.run(self.driver.reset_errors())
        self.run(self.driver.enable())
        until(lambda: self.driver.state().flags.ready, what="ready")


@pytest.fixture
def driven(emulator: subprocess.Popen[str]) -> Iterator[Driven]:
    d = Driven()
    yield d
    d.close()


def refused(driver: URDriver, why: str) -> bool:
    return why in driver.state().error_message


def test_a_controller_that_is_another_arm_is_refused_before_the_script_goes_up(
    emulator: subprocess.Popen[str],
) -> None:
    """The emulator is a UR5e (it says "UR5" on PolyScope 5); a driver started for a UR10e,
    or for a CB3 UR5, neither uploads its script nor takes the arm: it says what is wrong."""
    uploads = emulated()["scripts"]
    for model, says in (("ur10e", "not a ur10e (e-Series)"), ("ur5", "not a ur5 (CB3)")):
        info = load_robot_info(model)
        identity = DeviceIdentity(uuid=f"ur-{model}", kind="robot", model=info.model, name=model)
        driver = URDriver(identity, info, HOST)
        loop = asyncio.new_event_loop()
        loop.run_until_complete(driver.start())
        try:
            until(partial(refused, driver, says), what=f"{model} refused")
            message = driver.state().error_message
            assert "the controller is a UR5 (e-Series)" in message and "--model" in message
            with pytest.raises(RobotError, match="reset errors first"):
                loop.run_until_complete(driver.enable())
            with pytest.raises(RobotError, match="not connected"):
                loop.run_until_complete(driver.reset_errors())
        finally:
            loop.run_until_complete(driver.shutdown())
            loop.close()
    assert emulated()["scripts"] == uploads
    assert emulated()["runtime_state"] != PLAYING


def test_the_state_follows_the_controller(driven: Driven) -> None:
    until(lambda: not driven.driver.state().flags.communication_failure, what="connected")
    state = driven.driver.state()
    assert not state.flags.error and not state.flags.enabled
    assert np.allclose(state.joint_position, emulated()["q"], atol=1e-9)
    driven.ready()
    world("digital input 1 on")
    until(lambda: driven.driver.state().digital_inputs[1], what="DI1 seen")
    assert emulated()["watchdog_hz"] == 10.0  # set on connecting: a dead driver stops it


def test_outputs_are_written_while_the_arm_jogs_and_it_goes_on(driven: Driven) -> None:
    """ur-rtde's I/O interface stops every thread of its process for 100 ms while it
    connects: made in the driver's process, each output written cost the control thread the
    RTDE watchdog, which stopped the control program. Made in the writer's process, a jog
    goes on through ten writes, each shown in the state answered."""
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    start = d.state().joint_position[0]
    for k in range(5):
        value = k % 2 == 0
        driven.run(d.jog_joint(JogJointCommand(velocity=[0.1, 0, 0, 0, 0, 0], timeout=0.5)))
        state = driven.run(d.set_digital_output(2, DigitalOutputCommand(value=value)))
        assert state.digital_outputs[2] is value
        assert bool(emulated()["digital_outputs"] >> 2 & 1) is value
        state = driven.run(d.set_tool(ToolCommand(open=not value)))
        assert state.tool_open is (not value)
    state = d.state()
    assert not state.flags.error and state.flags.ready, state.error_message
    assert emulated()["runtime_state"] == PLAYING
    assert state.joint_position[0] > start + 0.05  # it jogged all along


def test_a_jog_moves_while_commanded_and_stops_after_its_timeout(driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    start = d.state().joint_position[0]
    velocity = [0.2, 0, 0, 0, 0, 0]
    for _ in range(30):  # 0.3 s of presses at 100 Hz
        driven.run(d.jog_joint(JogJointCommand(velocity=velocity, timeout=0.1)))
        time.sleep(0.01)
    until(lambda: abs(emulated()["qd"][0]) < 1e-6, 5, "stopped once the commands stopped")
    assert d.state().joint_position[0] > start + 0.02
    assert emulated()["runtime_state"] == 2  # stopped by the driver, not by the watchdog


def test_the_pendants_operational_mode_is_followed(driven: Driven) -> None:
    """No mode selection on the controller (UR's default): jogged as in manual mode, at
    reduced speed. Automatic on its pendant: the robot halts and the runtime refuses to jog
    it; manual again: reduced speed."""
    driven.ready()
    d = driven.driver
    assert d.state().operational_mode is OperationalMode.manual_reduced_speed
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    world("operational mode automatic")
    try:
        until(lambda: d.state().operational_mode is OperationalMode.auto, 5, "automatic seen")
        assert d.state().command_mode is CommandMode.halt
        world("operational mode manual")
        until(
            lambda: d.state().operational_mode is OperationalMode.manual_reduced_speed,
            5,
            "manual seen",
        )
    finally:
        world("operational mode none")


def test_a_hung_dashboard_does_not_hold_up_the_arm(driven: Driven) -> None:
    """The operational mode is asked on a dashboard connection and a thread of its own:
    while the dashboard answers nothing (3 s), jogging goes on and the RTDE watchdog never
    stops the script."""
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    world("dashboard stall 3")
    try:
        start = d.state().joint_position[0]
        for _ in range(200):  # 2 s of presses at 100 Hz, through at least one mode question
            driven.run(d.jog_joint(JogJointCommand(velocity=[0.2, 0, 0, 0, 0, 0], timeout=0.1)))
            time.sleep(0.01)
        assert emulated()["runtime_state"] == PLAYING  # the watchdog did not stop it
        state = d.state()
        assert not state.flags.error, state.error_message
        assert state.joint_position[0] > start + 0.1
    finally:
        world("dashboard stall 0")
    until(lambda: abs(emulated()["qd"][0]) < 1e-6, 5, "stopped once the presses stopped")


def test_freedrive_is_teach_mode_only_while_commanded(driven: Driven) -> None:
    """Held free by hand (teach mode) while freedrive commands come; when they stop, the
    controller leaves teach mode and the arm holds where the hand left it."""
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.freedrive)))
    world("hand 0 0 0 0.3 0 0")  # a hand on the wrist: it moves nothing yet
    try:
        start = np.array(emulated()["q"])
        assert not emulated()["freedrive"]
        taught = False
        for _ in range(50):  # 0.5 s of a held button at 100 Hz
            driven.run(d.freedrive(FreedriveCommand(timeout=0.1)))
            taught = taught or emulated()["freedrive"]
            time.sleep(0.01)
        assert taught and d.state().command_mode is CommandMode.freedrive
        until(lambda: not emulated()["freedrive"], 5, "teach mode ended when the commands did")
        moved = np.array(emulated()["q"]) - start
        assert moved[3] > 0.05 and np.allclose(np.delete(moved, 3), 0.0, atol=1e-6)
        until(lambda: abs(emulated()["qd"][3]) < 1e-9, 2, "the arm held")
        held = np.array(emulated()["q"])
        time.sleep(0.2)  # the hand still pushes: the arm stays
        assert np.allclose(emulated()["q"], held, atol=1e-6)
        assert emulated()["runtime_state"] == PLAYING  # not stopped by the watchdog
    finally:
        world("hand 0 0 0 0 0 0")


def test_a_trajectory_runs_on_its_planned_path_and_a_halt_stops_the_next(driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory)))
    start = np.array(d.state().joint_position)
    offsets = np.array([0.4, -0.3, 0.3, 0.2, 0.3, -0.4])
    times = np.linspace(0.2, 2.0, 10)
    waypoints = [
        TrajectoryWaypoint(time_from_start=float(t), position=(start + offsets * t / 2.0).tolist())
        for t in times
    ]
    accepted = driven.run(d.execute_trajectory(JointTrajectory(waypoints=waypoints)))
    seen: list[list[float]] = []
    deadline = time.monotonic() + 10
    while driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.running:
        seen.append(d.state().joint_position)
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.finished
    assert np.abs(np.array(emulated()["q"]) - (start + offsets)).max() < 1e-3
    # Every position the controller reported lies within 1 mm (at the TCP) of the plan.
    kinematics = Kinematics(UR5E)
    planned = np.array(
        [kinematics.tcp_pose(start + offsets * s).position for s in np.linspace(0, 1, 2001)]
    )
    gaps = [
        np.linalg.norm(planned - np.array(kinematics.tcp_pose(np.array(q)).position), axis=1).min()
        for q in seen
    ]
    assert max(gaps) < 1e-3, max(gaps)

    back = [TrajectoryWaypoint(time_from_start=2.0, position=start.tolist())]
    accepted = driven.run(d.execute_trajectory(JointTrajectory(waypoints=back)))
    until(lambda: abs(emulated()["qd"][0]) > 0.05, 5, "moving back")
    driven.run(d.halt())
    assert driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.aborted
    until(lambda: max(abs(v) for v in emulated()["qd"]) < 1e-6, 5, "halted")


def test_a_protective_stop_is_a_fault_until_reset_and_nothing_resumes(driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    press = JogJointCommand(velocity=[0.2, 0, 0, 0, 0, 0], timeout=1.0)
    driven.run(d.jog_joint(press))
    until(lambda: emulated()["qd"][0] > 0.1, 5, "jogging")
    world("protective stop")
    until(lambda: d.state().flags.error, 5, "the fault seen")
    state = d.state()
    assert "protective stop" in state.error_message and not state.flags.ready
    assert state.flags.protective_stop and not state.flags.estop
    assert state.command_mode is CommandMode.halt
    until(lambda: max(abs(v) for v in emulated()["qd"]) < 1e-6, 5, "halted")
    driven.run(d.reset_errors())  # unlocks it through the dashboard
    until(lambda: emulated()["safety_mode"] == 1, 5, "unlocked")
    # Within the first press's timeout: neither it nor a new one moves the arm (halted,
    # disabled) until the user enables it again.
    with pytest.raises(RobotError):
        driven.run(d.jog_joint(press))
    time.sleep(0.1)
    assert max(abs(v) for v in emulated()["qd"]) < 1e-6
    driven.run(d.enable())  # the control script again
    until(lambda: d.state().flags.ready, 5, "ready again")
    assert emulated()["runtime_state"] == 2
    assert not d.state().flags.protective_stop


def test_the_runtimes_protective_stop_stops_the_arm_and_holds_until_reset(
    driven: Driven,
) -> None:
    """The path monitor's stop: the arm stops, and nothing moves it until errors are reset
    and it is enabled again."""
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    press = JogJointCommand(velocity=[0.2, 0, 0, 0, 0, 0], timeout=1.0)
    driven.run(d.jog_joint(press))
    until(lambda: emulated()["qd"][0] > 0.1, 5, "jogging")
    reason = "the TCP left its planned path by 6.2 mm (tolerance 5.0 mm)"
    state = driven.run(d.protective_stop(ProtectiveStopRequest(reason=reason)))
    assert state.flags.error and reason in state.error_message
    until(lambda: max(abs(v) for v in emulated()["qd"]) < 1e-6, 5, "halted")
    with pytest.raises(RobotError):
        driven.run(d.jog_joint(press))
    driven.run(d.reset_errors())
    driven.run(d.enable())
    until(lambda: d.state().flags.ready, 5, "ready again")


def test_reduced_mode_is_shown_and_the_arm_still_jogs(driven: Driven) -> None:
    """The safety system's reduced limits (a safeguard, a plane crossed) are not a stop."""
    driven.ready()
    d = driven.driver
    world("reduced on")
    try:
        until(lambda: d.state().flags.reduced_speed, 5, "reduced mode seen")
        assert d.state().flags.ready and not d.state().flags.error
        driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
        start = d.state().joint_position[0]
        for _ in range(20):
            driven.run(d.jog_joint(JogJointCommand(velocity=[0.2, 0, 0, 0, 0, 0], timeout=0.1)))
            time.sleep(0.01)
        until(lambda: abs(emulated()["qd"][0]) < 1e-6, 5, "stopped after the presses")
        assert d.state().joint_position[0] > start + 0.01
    finally:
        world("reduced off")
    until(lambda: not d.state().flags.reduced_speed, 5, "normal mode seen")


def test_a_lost_connection_comes_back_by_itself_and_nothing_moves(
    emulator: subprocess.Popen[str],
) -> None:
    driven = Driven()
    try:
        driven.ready()
        d = driven.driver
        stop_emulator(emulator)
        until(lambda: d.state().flags.communication_failure, 10, "the loss seen")
        assert d.state().flags.error and not d.state().flags.enabled
        again = start_emulator()
        try:
            until(lambda: not d.state().flags.communication_failure, 15, "reconnected")
            state = d.state()
            assert state.flags.error and "reset errors" in state.error_message
            assert not state.flags.ready and not state.flags.enabled
            time.sleep(0.2)  # connected for a while: still nothing commanded
            assert max(abs(v) for v in emulated()["qd"]) < 1e-9
            driven.ready()  # reset, enable: the user's decision
            assert emulated()["runtime_state"] == 2
        finally:
            driven.close()
            stop_emulator(again)
    except BaseException:
        driven.loop.close()
        raise


OUTAGE = 2.0  # s of the states while the controller is away (it flapped every 0.2-0.4 s)


def test_a_controller_gone_is_a_steady_fault_in_the_runtime_not_a_flapping_link(
    emulator: subprocess.Popen[str], tmp_path: Path
) -> None:
    """Issue 31: while the controller is away, `GET /api/devices/robot` stays connected on
    one link (it alternated between connected and stale every 0.2-0.4 s: the driver's states
    stopped counting), and the robot's state says error with `communication_failure`. Back,
    it is still an error until reset."""
    runtime = Runtime(tmp_path, extra=["--no-sim"])
    driver = DriverProc(tmp_path, "ur-rtde", "ur", "--address", HOST, "--model", "ur5e")
    again: subprocess.Popen[str] | None = None
    try:
        runtime.wait_ready()
        added = runtime.api(
            "POST", "/devices", json={"url": driver.wait_ready(), "local_name": "robot"}
        )
        assert added.status_code in (200, 201), added.text

        def state() -> dict[str, Any]:
            answer = runtime.api("GET", "/devices/robot/state")
            return answer.json() if answer.status_code == 200 else {}

        until(lambda: state().get("flags", {}).get("error") is False, 20, "the UR connected")
        link = runtime.api("GET", "/devices/robot").json()["link"]
        stop_emulator(emulator)
        seen: set[tuple[str, int]] = set()
        outage: list[dict[str, Any]] = []
        # Said within the driver's watchdog, then watched for OUTAGE s of states.
        deadline = time.monotonic() + 10.0 + OUTAGE
        while not outage or outage[-1]["ts"] < outage[0]["ts"] + OUTAGE:
            details = runtime.api("GET", "/devices/robot").json()
            seen.add((details["status"], details["link"]))
            now = state()
            if now.get("flags", {}).get("communication_failure"):
                outage.append(now)
            assert len(seen) == 1, seen
            assert time.monotonic() < deadline, (
                f"{len(outage)} states with the controller away; the last: {now}; link: {details}"
            )
        assert seen == {("connected", link)}
        assert all(s["flags"]["error"] and not s["flags"]["ready"] for s in outage)
        assert "cannot reach the robot" in outage[-1]["error_message"]
        again = start_emulator()
        until(lambda: not state()["flags"]["communication_failure"], 15, "the controller back")
        back = state()
        assert back["flags"]["error"] and "reset errors" in back["error_message"]
        assert runtime.api("GET", "/devices/robot").json()["link"] == link
    finally:
        stop_all([driver, runtime])
        if again is not None:
            stop_emulator(again)


DRIVER_THAT_DIES = f"""
import asyncio, time
from openpendant.device_drivers.ur_rtde.driver import URDriver
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.robot import CommandMode, CommandModeRequest, JogJointCommand
from openpendant.runtime.robotics.robot_info import load_robot_info

async def main():
    info = load_robot_info("ur5e")
    identity = DeviceIdentity(uuid="u", kind="robot", model=info.model, name="ur")
    d = URDriver(identity, info, {HOST!r})
    await d.start()
    while d.state().flags.communication_failure:
        await asyncio.sleep(0.01)
    await d.enable()
    await d.set_command_mode(CommandModeRequest(mode=CommandMode.jog))
    print("moving", flush=True)
    while True:
        await d.jog_joint(JogJointCommand(velocity=[0.1, 0, 0, 0, 0, 0], timeout=0.2))
        await asyncio.sleep(0.01)

asyncio.run(main())
"""


def test_the_watchdog_stops_the_arm_when_the_drivers_process_dies(
    emulator: subprocess.Popen[str],
) -> None:
    process = subprocess.Popen(
        [sys.executable, "-c", DRIVER_THAT_DIES], stdout=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout is not None
        assert process.stdout.readline().strip() == "moving"
        until(lambda: emulated()["qd"][0] > 0.09, 5, "jogging")
        process.kill()  # no goodbye, no stop
        process.wait(5)
        until(lambda: emulated()["runtime_state"] == 1, 5, "the program stopped")
        until(lambda: abs(emulated()["qd"][0]) < 1e-6, 5, "the arm halted")
    finally:
        process.kill()
        process.wait(5)
