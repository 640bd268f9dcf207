"""A Robot Raconteur standard robot in a runtime (issue 35, must-show 1 but for RR's
discovery): the simulated RR arm (tests/support/rr_sim_arm.py) served by the rr-robot
driver, added by its driver's URL, as the Devices panel adds it. Its state at the API, a
held jog that stops on release, a planned linear move that keeps to its line (the path
monitor at its defaults), its E-stop shown as E-STOP, and the RR robot killed mid-move: a
fault, the move failed, nothing resumes."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.bench.harness.jog import JogClient
from openpendant.runtime.bench.harness.processes import DriverProc, Runtime, stop_all, wait_for
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.robotics.kinematics import Kinematics, se3_to_pose
from tests.integration.test_rr_robot_driver import Arm


class Cell:
    def __init__(self, runtime: Runtime, arm: Arm, driver: DriverProc) -> None:
        self.runtime, self.arm, self.driver = runtime, arm, driver
        described = runtime.api("GET", "/devices/robot").json()["info"]
        self.kinematics = Kinematics(RobotInfo.model_validate(described["info"]))
        self.token = ""

    def state(self) -> dict[str, Any]:
        return self.runtime.api("GET", "/devices/robot/state").json()  # type: ignore[no-any-return]

    def q(self) -> np.ndarray[Any, Any]:
        return np.array(self.state()["joint_position"])

    def at_rest(self) -> bool:
        return bool(np.abs(self.state()["joint_velocity"]).max() < 1e-6)

    def headers(self) -> dict[str, str]:
        return {"X-Lease-Token": self.token}

    def take_control_and_enable(self) -> None:
        if not self.token:
            taken = self.runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"})
            assert taken.status_code == 200, taken.text
            self.token = taken.json()["token"]
        enabled = self.runtime.api("POST", "/jog/robots/robot/enable", headers=self.headers())
        assert enabled.status_code == 200, enabled.text


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    home = tmp_path_factory.mktemp("rr-cell")
    arm = Arm()
    runtime = Runtime(home, extra=["--no-sim"])  # the path monitor at its defaults
    driver = DriverProc(home, "rr-robot", "rr-arm", "--url", arm.url)
    try:
        runtime.wait_ready()
        url = driver.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "robot"})
        assert added.status_code in (200, 201), added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/robot").json()["status"] == "connected",
            20,
            what="the RR robot connected",
        )
        yield Cell(runtime, arm, driver)
    finally:
        stop_all([driver, runtime])
        arm.stop()


def test_its_state_jog_and_a_linear_move_through_the_runtime(cell: Cell) -> None:
    state = cell.state()
    assert state["joint_position"] == pytest.approx([0.0, -1.2, 1.4, -1.8, -1.57, 0.0], abs=1e-6)
    assert not state["flags"]["error"] and not state["flags"]["estop"]
    cell.take_control_and_enable()
    jog = JogClient(cell.runtime, token=cell.token)
    try:
        before = cell.kinematics.tcp(cell.q()).copy()
        jog.hold(0.5, kind="cartesian", axis="z", direction=1, frame="base", speed=0.4)
        wait_for(cell.at_rest, 5, what="stopped on release")
        after = cell.kinematics.tcp(cell.q())
        moved = after.translation - before.translation
        assert moved[2] > 0.005 and np.abs(moved[:2]).max() < 1e-3

        # Held, then the heartbeats stop (a dropped finger, a frozen tablet): the deadman.
        press = jog.press(kind="joint", axis=0, direction=1, speed=0.3)
        with jog.held(press):
            assert jog.status(press, ("moving", "refused"))["state"] == "moving"
            wait_for(lambda: not cell.at_rest(), 5, what="jogging")
        wait_for(cell.at_rest, 2, what="stopped without heartbeats")
        stopped = cell.q()
        time.sleep(0.3)
        assert np.abs(cell.q() - stopped).max() < 1e-9
    finally:
        jog.close()

    start = cell.kinematics.tcp(cell.q()).copy()
    goal = pin.SE3(start.rotation, start.translation + np.array([0.0, 0.15, -0.05]))
    request = {"kind": "linear", "target": {"pose": se3_to_pose(goal).model_dump()}, "speed": 0.5}
    answer = cell.runtime.api(
        "POST", "/motion/robots/robot/moves", json=request, headers=cell.headers()
    )
    assert answer.status_code == 202, answer.text
    status = answer.json()
    seen: list[np.ndarray[Any, Any]] = []
    while status["state"] in ("planning", "running"):
        seen.append(cell.kinematics.tcp(cell.q()).translation.copy())
        status = cell.runtime.api("GET", f"/motion/moves/{status['id']}").json()
    assert status["state"] == "finished", status
    end = cell.kinematics.tcp(cell.q())
    assert np.linalg.norm(end.translation - goal.translation) < 1e-3
    # Every position seen on the way within the path monitor's 5 mm of the line.
    direction = (goal.translation - start.translation) / np.linalg.norm(
        goal.translation - start.translation
    )
    off = [
        np.linalg.norm((p - start.translation) - direction * ((p - start.translation) @ direction))
        for p in seen
    ]
    assert len(seen) > 5 and max(off) < 5e-3, max(off)


def test_its_estop_is_shown_and_its_loss_mid_move_is_a_fault_nothing_resumes(cell: Cell) -> None:
    cell.take_control_and_enable()
    cell.arm.estop(True)
    wait_for(lambda: cell.state()["flags"]["estop"], 5, what="E-STOP shown")
    assert cell.state()["flags"]["error"]
    cell.arm.estop(False)
    wait_for(lambda: not cell.state()["flags"]["estop"], 5, what="E-stop released")
    reset = cell.runtime.api("POST", "/jog/robots/robot/reset_errors", headers=cell.headers())
    assert reset.status_code == 200, reset.text
    cell.take_control_and_enable()

    start = cell.kinematics.tcp(cell.q()).copy()
    goal = pin.SE3(start.rotation, start.translation + np.array([0.0, -0.3, 0.0]))
    request = {"kind": "linear", "target": {"pose": se3_to_pose(goal).model_dump()}, "speed": 0.2}
    answer = cell.runtime.api(
        "POST", "/motion/robots/robot/moves", json=request, headers=cell.headers()
    )
    assert answer.status_code == 202, answer.text
    move = answer.json()["id"]
    wait_for(lambda: not cell.at_rest(), 10, what="the move under way")
    cell.arm.kill()
    status = wait_for(
        lambda: (
            (s := cell.runtime.api("GET", f"/motion/moves/{move}").json())["state"]
            not in ("planning", "running")
            and s
        ),
        10,
        what="the move ended",
    )
    assert status["state"] == "failed", status
    state = wait_for(
        lambda: (s := cell.state())["flags"]["communication_failure"] and s, 10, what="the fault"
    )
    assert state["flags"]["error"]
    held = cell.q()
    again = cell.runtime.api("POST", "/jog/robots/robot/enable", headers=cell.headers())
    assert again.status_code >= 400
    assert np.abs(cell.q() - held).max() < 1e-9
