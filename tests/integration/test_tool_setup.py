"""A robot's tool setup (TCP and payload): set by whoever controls the robot, stored as
`tools.<robot>`, reported by the driver, used by jogging (a rotation turns about the new
TCP), checked against the rated payload, and applied again when the robot reconnects."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import (
    Runtime,
    SimRobotProc,
    child_env,
    free_port,
    wait_for,
)

TOOL = {
    "tcp": {"position": [0.0, 0.0, 0.15], "orientation": [0.0, 0.0, 0.0, 1.0]},
    "payload": {"mass": 1.2, "center_of_mass": [0.0, 0.0, 0.08]},
}


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    home = tmp_path_factory.mktemp("tools")
    runtime = Runtime(home, env=child_env(home, OPENPENDANT_DEADMAN_SECONDS="0.5"))
    runtime.wait_ready()
    try:
        yield Cell(runtime)
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


def tcp_pose(runtime: Runtime, robot: str = "robot") -> pin.SE3:
    pose = runtime.api("GET", f"/devices/{robot}/state").json()["tcp_pose"]
    x, y, z, w = pose["orientation"]
    return pin.SE3(pin.Quaternion(w, x, y, z).toRotationMatrix(), np.array(pose["position"]))


def info(runtime: Runtime, robot: str = "robot") -> dict[str, Any]:
    return runtime.api("GET", f"/devices/{robot}").json()["info"]["info"]  # type: ignore[no-any-return]


def test_a_tool_is_set_by_whoever_controls_the_robot_and_jogging_turns_about_its_tcp(
    cell: Cell,
) -> None:
    cell.ready()
    runtime = cell.runtime
    flange = tcp_pose(runtime)

    refused = runtime.api("PUT", "/devices/robot/tool", json=TOOL)
    assert refused.status_code in (401, 403, 409, 423), refused.text
    assert runtime.api("GET", "/variables/tools.robot").status_code == 404

    response = runtime.api("PUT", "/devices/robot/tool", json=TOOL, headers=cell.headers())
    assert response.status_code == 200, response.text
    assert response.json()["payload"]["mass"] == pytest.approx(1.2)
    stored = runtime.api("GET", "/variables/tools.robot").json()
    assert stored["type"] == "tool" and stored["value"]["tcp"]["position"][2] == 0.15
    # The driver now reports the TCP 150 mm out along the flange's z axis.
    expected = flange.translation + flange.rotation @ np.array([0.0, 0.0, 0.15])
    wait_for(
        lambda: np.linalg.norm(tcp_pose(runtime).translation - expected) < 1e-4,
        5,
        what="the new TCP reported",
    )
    # The jog service's model has it too.
    model = runtime.api("GET", "/jog/robots/robot").json()
    assert model["info"]["tcp"]["position"] == [0.0, 0.0, 0.15]

    # Turning about base z keeps the new TCP where it is (about the flange it would swing).
    cell.ready()  # the tool change halted the robot
    client = JogClient(runtime, token=cell.token)
    try:
        wait_for(
            lambda: (
                runtime.api("GET", "/jog/robots/robot").json()["info"]["tcp"]["position"][2] == 0.15
            ),
            5,
        )
        before = tcp_pose(runtime)
        client.hold(0.8, kind="cartesian", axis="rz", direction=1, frame="base", speed=0.5)
        cell.robot.wait_stopped(5)
        after = tcp_pose(runtime)
    finally:
        client.close()
    turned = math.degrees(abs(pin.log3(after.rotation @ before.rotation.T)[2]))
    assert turned > 2.0, turned
    assert np.linalg.norm(after.translation - before.translation) < 0.001


def test_a_payload_over_the_rating_is_refused_and_changes_nothing(cell: Cell) -> None:
    cell.ready()
    runtime = cell.runtime
    heavy = {**TOOL, "payload": {"mass": 6.5, "center_of_mass": [0.0, 0.0, 0.0]}}
    response = runtime.api("PUT", "/devices/robot/tool", json=heavy, headers=cell.headers())
    assert response.status_code == 422, response.text
    assert "rated payload of 5 kg" in response.json()["error"]["message"]
    far = {**TOOL, "tcp": {"position": [0.0, 0.0, 5.0]}}
    response = runtime.api("PUT", "/devices/robot/tool", json=far, headers=cell.headers())
    assert response.status_code == 422, response.text
    nan = {**TOOL, "payload": {"mass": "NaN"}}
    response = runtime.api("PUT", "/devices/robot/tool", json=nan, headers=cell.headers())
    assert response.status_code == 422, response.text
    stored = runtime.api("GET", "/variables/tools.robot")
    if stored.status_code == 200:  # the first test's tool, untouched
        assert stored.json()["value"]["payload"]["mass"] == pytest.approx(1.2)


def test_a_robot_that_reconnects_gets_its_stored_tool_again(cell: Cell, tmp_path: Path) -> None:
    runtime = cell.runtime
    port = free_port()
    sim = SimRobotProc(tmp_path, name="tool-arm", port=port)
    sim.wait_ready()

    def discovered() -> bool:
        return any(d["uuid"] == sim.uuid for d in runtime.api("GET", "/devices/detected").json())

    try:
        # Ready is not yet seen: the runtime adds by uuid only what its discovery has found.
        wait_for(discovered, 10, what="the robot discovered")
        pairing = {"uuid": sim.uuid, "local_name": "arm2", "pairing": sim.secret}
        added = runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        wait_for(lambda: runtime.api("GET", "/devices/arm2").json()["status"] == "connected", 10)
        token = runtime.api("POST", "/devices/arm2/lease", json={"holder": "tests"}).json()["token"]
        response = runtime.api(
            "PUT", "/devices/arm2/tool", json=TOOL, headers={"X-Lease-Token": token}
        )
        assert response.status_code == 200, response.text

        sim.stop()  # the robot restarts: it comes back with its own default TCP ...
        wait_for(lambda: runtime.api("GET", "/devices/arm2").json()["status"] != "connected", 10)
        sim = SimRobotProc(tmp_path, name="tool-arm", port=port)
        sim.wait_ready()
        wait_for(lambda: runtime.api("GET", "/devices/arm2").json()["status"] == "connected", 10)
        # ... and is given the stored one before anything can move it.
        assert info(runtime, "arm2")["tcp"]["position"] == [0.0, 0.0, 0.15]
        assert info(runtime, "arm2")["payload"]["mass"] == pytest.approx(1.2)
    finally:
        runtime.api("DELETE", "/devices/arm2")
        sim.stop()
