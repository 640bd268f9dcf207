"""Must-show 1, the UR half: the Blockly pick and place of test_sim_cell, unchanged, on a UR
(the UR driver through ur-rtde to the controller emulator) with the simulated Modbus I/O
block and Robotiq gripper mounted on it: the part ends at the place position. The same
controller's own I/O (the ur-io driver) through the same I/O blocks."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from openpendant.device_drivers.sim_cell.link import CellClient
from openpendant.device_drivers.ur_rtde.emulator import control as emulator_control
from openpendant.runtime.bench.harness.blocks import block, number, stack, workspace
from openpendant.runtime.bench.harness.jog import JogClient
from openpendant.runtime.bench.harness.processes import (
    DriverProc,
    Runtime,
    child_env,
    stop_all,
    wait_for,
)
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.integration.test_sim_cell import pick_and_place_with_the_cells_devices, tcp_at
from tests.support.programs import ABOVE_PICK, ABOVE_PLACE, PICK, PLACE, teach

HOST = "127.0.0.5"
UR5E = Kinematics(load_robot_info("ur5e"))  # the emulated arm
CELL = "ur-emulated"


def ask(runtime: Runtime, op: str, **args: Any) -> dict[str, Any]:
    answer = asyncio.run(CellClient(CELL, runtime.data_dir).ask(op, **args))
    assert answer is not None, f"no cell {CELL}"
    return answer


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Runtime, str]]:
    home: Path = tmp_path_factory.mktemp("ur-cell")
    emulator = subprocess.Popen(
        [sys.executable, "-u", "-m", "openpendant.device_drivers.ur_rtde.emulator"]
        + ["--host", HOST, "--cell", CELL],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=child_env(home),
    )
    runtime = Runtime(home, extra=["--no-sim"])  # the path monitor at its defaults
    devices = [
        ("robot", DriverProc(home, "ur-rtde", "ur", "--address", HOST, "--model", "ur5e")),
        ("cell_io", DriverProc(home, "modbus-io", "cell-io", "--simulate", "--cell", CELL)),
        ("ur_io", DriverProc(home, "ur-io", "ur-io", "--address", HOST)),
        (
            "gripper",
            DriverProc(home, "modbus-gripper", "robotiq", "--simulate", "--mounted-on", CELL),
        ),
    ]
    try:
        assert emulator.stdout is not None and "ready" in emulator.stdout.readline()
        runtime.wait_ready()
        for local_name, device in devices:
            url = device.wait_ready()
            added = runtime.api("POST", "/devices", json={"url": url, "local_name": local_name})
            assert added.status_code in (200, 201), added.text
        teach(
            runtime,
            {"above_pick": ABOVE_PICK, "pick": PICK, "above_place": ABOVE_PLACE, "place": PLACE},
        )
        yield runtime, HOST
    finally:
        stop_all([*(device for _, device in devices), runtime])
        emulator.terminate()
        emulator.communicate(timeout=10)


def test_the_blockly_pick_and_place_runs_unchanged_on_the_ur(cell: tuple[Runtime, str]) -> None:
    runtime, _ = cell
    pick = tcp_at(PICK, UR5E)
    ask(
        runtime,
        "layout",
        setup={
            "parts": [{"id": "cube", "size": [0.04, 0.04, 0.04], "pose": {"position": pick}}],
            "sensors": {"part_present": {"position": pick, "radius": 0.03}},
        },
    )
    wait_for(
        lambda: (
            runtime.api("GET", "/devices/robot/state").json().get("flags", {}).get("error") is False
        ),
        20,
        what="the UR connected",
    )
    lease = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]
    mine = {"X-Lease-Token": lease}
    enabled = runtime.api("POST", "/jog/robots/robot/enable", headers=mine)
    assert enabled.status_code == 200, enabled.text
    saved = runtime.api(
        "PUT", "/programs/ur_cycle", json={"workspace": pick_and_place_with_the_cells_devices()}
    )
    assert saved.status_code == 200, saved.text
    started = runtime.api("POST", "/programs/ur_cycle/run", json={"leases": {"robot": lease}})
    assert started.status_code == 202, started.text

    final = wait_for(ended(runtime, "ur_cycle"), 120, what="the cycle's end")
    assert final["state"] == "finished", final.get("error")
    part = next(p for p in ask(runtime, "parts")["parts"] if p["id"] == "cube")
    x, y, z = part["pose"]["position"]
    assert part["held"] is False
    assert np.allclose([x, y], tcp_at(PLACE, UR5E)[:2], atol=1e-3), (part, tcp_at(PLACE, UR5E))
    assert z == pytest.approx(0.02)
    state = runtime.api("GET", "/devices/cell_io/state").json()
    assert state["values"]["lamp_green"] is True
    runtime.api("DELETE", "/devices/robot/lease", headers=mine)


def ended(runtime: Runtime, program: str) -> Any:
    def check() -> dict[str, Any] | None:
        status: dict[str, Any] = runtime.api("GET", f"/programs/{program}/status").json()
        return status if status["state"] in ("finished", "error", "stopped") else None

    return check


def test_the_controllers_own_io_through_the_io_blocks(cell: tuple[Runtime, str]) -> None:
    """Digital, analog and tool I/O of the UR controller (ur-io), by the blocks every I/O
    block answers: an output set, an analog output in volts, a wait for the tool input, an
    analog input stored."""
    runtime, host = cell
    emulator_control.world(host, "digital input 16 off")
    emulator_control.world(host, "analog input 1 3.25")
    main = stack(
        block(
            "io_set_output", {"NAME": "ur_io.do2"}, VALUE=block("logic_boolean", {"BOOL": "TRUE"})
        ),
        block("io_set_analog", {"NAME": "ur_io.ao0"}, VALUE=number(5)),
        block("io_wait_input", {"NAME": "ur_io.ti0", "STATE": "TRUE"}, TIMEOUT=number(20)),
        block("store_set", {"NAME": "ur_ai1"}, VALUE=block("io_get_analog", {"NAME": "ur_io.ai1"})),
    )
    saved = runtime.api("PUT", "/programs/ur_io_cycle", json={"workspace": workspace(main)})
    assert saved.status_code == 200, saved.text
    started = runtime.api("POST", "/programs/ur_io_cycle/run", json={})
    assert started.status_code == 202, started.text
    wait_for(
        lambda: abs(emulator_control.emulated(host)["analog_outputs"][0] - 5.0) < 1e-6,
        20,
        what="AO0 at 5 V",
    )
    assert emulator_control.emulated(host)["digital_outputs"] >> 2 & 1  # set before AO0
    assert runtime.api("GET", "/programs/ur_io_cycle/status").json()["state"] == "running"
    emulator_control.world(host, "digital input 16 on")  # the tool's sensor
    final = wait_for(ended(runtime, "ur_io_cycle"), 30, what="the program's end")
    assert final["state"] == "finished", final.get("error")
    stored = runtime.api("GET", "/variables/ur_ai1").json()
    assert stored["value"] == pytest.approx(3.25), stored
    state = runtime.api("GET", "/devices/ur_io/state").json()
    assert state["values"]["do2"] is True and state["values"]["ti0"] is True


def test_the_ur_is_jogged_and_freedriven_through_the_jog_socket(cell: tuple[Runtime, str]) -> None:
    """What the Jog panel sends, on the UR: a Cartesian jog up along the base z axis (the
    runtime's kinematics, joint velocities to the controller) keeps its line; Freedrive held
    puts the controller in teach mode, where a hand moves the arm; let go, it holds."""
    runtime, host = cell
    lease = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]
    mine = {"X-Lease-Token": lease}
    assert runtime.api("POST", "/jog/robots/robot/enable", headers=mine).status_code == 200
    jog = JogClient(runtime, token=lease)
    try:
        before = joints(runtime)
        jog.hold(0.5, kind="cartesian", axis="z", direction=1, frame="base", speed=0.4)
        wait_for(lambda: at_rest(runtime), 5, what="stopped on release")
        start, end = UR5E.tcp(before), UR5E.tcp(joints(runtime))
        moved = end.translation - start.translation
        assert moved[2] > 0.005 and np.abs(moved[:2]).max() < 1e-3
        assert np.linalg.norm(pin.log3(start.rotation.T @ end.rotation)) < 1e-3

        emulator_control.world(host, "hand 0.3 0 0 0 0 0")
        before = joints(runtime)
        press = jog.press(type="freedrive")
        with jog.held(press):
            assert jog.status(press, ("moving", "refused"))["state"] == "moving"
            wait_for(lambda: emulator_control.emulated(host)["freedrive"], 5, what="teach mode")
            wait_for(lambda: joints(runtime)[0] > before[0] + 0.05, 5, what="moved by hand")
        jog.send({"type": "release", "press": press})
        wait_for(lambda: not emulator_control.emulated(host)["freedrive"], 5, what="teach ended")
        wait_for(lambda: at_rest(runtime), 5, what="held where the hand left it")
    finally:
        emulator_control.world(host, "hand 0 0 0 0 0 0")
        jog.close()
        runtime.api("DELETE", "/devices/robot/lease", headers=mine)


def joints(runtime: Runtime) -> np.ndarray[Any, Any]:
    return np.array(runtime.api("GET", "/devices/robot/state").json()["joint_position"])


def at_rest(runtime: Runtime) -> bool:
    velocity = runtime.api("GET", "/devices/robot/state").json()["joint_velocity"]
    return bool(np.allclose(velocity, 0.0, atol=1e-9))
