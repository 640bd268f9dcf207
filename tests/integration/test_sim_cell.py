"""The simulated cell `make run` starts, as one world: a UR5 with parts on its table, its
Modbus I/O block whose `part_present` input sees a part at the pick place, and a Robotiq
gripper on its flange that grasps the part at the TCP when it closes and lets it fall when
it opens. A Blockly pick and place (issue 16, must-show 1, the simulated half) is checked
by where the part ends up."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from openpendant.runtime.bench.harness.blocks import block, number, stack, waypoint, workspace
from openpendant.runtime.bench.harness.jog import Cell
from openpendant.runtime.bench.harness.processes import (
    FAST_MOTION_ENV,
    Runtime,
    wait_for,
    whole_cell_env,
)
from openpendant.runtime.kit.settings import default_devices
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.support.programs import ABOVE_PICK, ABOVE_PLACE, HOME, PICK, PLACE, teach

UR5 = Kinematics(load_robot_info("ur5"))


def tcp_at(joints: list[float], arm: Kinematics = UR5) -> list[float]:
    return list(arm.tcp_pose(np.array(joints)).position)


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    home = tmp_path_factory.mktemp("sim-cell")
    runtime = Runtime(home, env=whole_cell_env(home, **FAST_MOTION_ENV))
    runtime.wait_ready()
    try:
        cell = Cell(runtime)
        for spec, local_name in zip(default_devices()[1:], ("cell_io", "gripper"), strict=True):
            uuid = runtime.own_device(spec)["uuid"]
            added = runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": local_name})
            assert added.status_code in (200, 201), added.text
        teach(
            runtime,
            {"above_pick": ABOVE_PICK, "pick": PICK, "above_place": ABOVE_PLACE, "place": PLACE},
        )
        yield cell
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


def lay_out(cell: Cell, part_at: list[float], sensor_at: list[float]) -> None:
    """One 40 mm cube, and the presence sensor `part_present` watching `sensor_at`."""
    layout = {
        "parts": [{"id": "cube", "size": [0.04, 0.04, 0.04], "pose": {"position": part_at}}],
        "sensors": {"part_present": {"position": sensor_at, "radius": 0.03}},
    }
    answer = cell.robot.http.put("/sim/cell", json=layout)
    assert answer.status_code == 200, answer.text


def run_python(cell: Cell, name: str, python: str) -> dict[str, Any]:
    """Saves and runs a hand-written program under the test's control of the robot."""
    saved = cell.runtime.api("PUT", f"/programs/{name}", json={"python": python})
    assert saved.status_code == 200, saved.text
    started = cell.runtime.api(
        "POST", f"/programs/{name}/run", json={"leases": {"robot": cell.token}}
    )
    assert started.status_code == 202, started.text

    def ended() -> dict[str, Any] | None:
        status: dict[str, Any] = cell.runtime.api("GET", f"/programs/{name}/status").json()
        return status if status["state"] in ("finished", "error", "stopped") else None

    final = wait_for(ended, 90, what=f"{name}'s end")
    assert final["state"] == "finished", final
    return final


def cube(cell: Cell) -> dict[str, Any]:
    parts: list[dict[str, Any]] = cell.robot.http.get("/sim/cell/parts").json()
    return next(p for p in parts if p["id"] == "cube")


def test_the_robots_own_tool_picks_the_part_at_its_tcp_and_drops_it_elsewhere(
    cell: Cell,
) -> None:
    cell.ready()
    cell.place(PICK)
    lay_out(cell, tcp_at(PICK), [9.0, 9.0, 9.0])
    run_python(cell, "tool_close", "use_robot('robot')\ntool_close()\n")
    assert cube(cell)["held"] is True
    cell.place(PLACE)
    # Held, it goes where the TCP goes.
    assert np.allclose(cube(cell)["pose"]["position"], tcp_at(PLACE), atol=1e-3)
    # The 3D view's source (through the gateway, as any signed-in user may read it): the
    # same, held, at the TCP; a device without a simulated cell has no parts to list.
    [shown] = cell.runtime.api("GET", "/devices/robot/cell/parts").json()
    assert shown["id"] == "cube" and shown["held"] is True
    assert np.allclose(shown["pose"]["position"], tcp_at(PLACE), atol=1e-3)
    none = cell.runtime.api("GET", "/devices/cell_io/cell/parts")
    assert none.status_code == 404 and none.json()["error"]["code"] == "no_cell", none.text
    run_python(cell, "tool_open", "use_robot('robot')\ntool_open()\n")
    fallen = cube(cell)
    assert fallen["held"] is False
    x, y, z = fallen["pose"]["position"]
    assert np.allclose([x, y], tcp_at(PLACE)[:2], atol=1e-3) and z == pytest.approx(0.02)
    cell.place(HOME)


def pick_and_place_with_the_cells_devices() -> dict[str, Any]:
    """Wait for a part, pick it with the Robotiq, place it, switch the green lamp on."""
    gripper = {"GRIPPER": "gripper"}
    main = stack(
        block("robot_use", {"ROBOT": "robot"}),
        block("robot_set_speed", SPEED=number(100)),
        block("gripper_activate", gripper),
        block("gripper_open", gripper),
        block(
            "io_wait_input", {"NAME": "cell_io.part_present", "STATE": "TRUE"}, TIMEOUT=number(10)
        ),
        block("robot_move_joint", TARGET=waypoint("above_pick")),
        block("robot_move_linear", TARGET=waypoint("pick")),
        block("gripper_close", gripper),
        block("gripper_wait_grip", gripper, TIMEOUT=number(5)),
        block("robot_move_linear", TARGET=waypoint("above_pick")),
        block("robot_move_joint", TARGET=waypoint("above_place")),
        block("robot_move_linear", TARGET=waypoint("place")),
        block("gripper_open", gripper),
        block("robot_move_linear", TARGET=waypoint("above_place")),
        block(
            "io_set_output",
            {"NAME": "cell_io.lamp_green"},
            VALUE=block("logic_boolean", {"BOOL": "TRUE"}),
        ),
    )
    return workspace(main)


def test_a_blockly_pick_and_place_moves_the_part_to_the_place_position(cell: Cell) -> None:
    cell.ready()
    cell.place(HOME)
    pick = tcp_at(PICK)
    lay_out(cell, pick, pick)
    saved = cell.runtime.api(
        "PUT", "/programs/cell_cycle", json={"workspace": pick_and_place_with_the_cells_devices()}
    )
    assert saved.status_code == 200, saved.text
    started = cell.runtime.api(
        "POST", "/programs/cell_cycle/run", json={"leases": {"robot": cell.token}}
    )
    assert started.status_code == 202, started.text

    def ended() -> dict[str, Any] | None:
        status: dict[str, Any] = cell.runtime.api("GET", "/programs/cell_cycle/status").json()
        return status if status["state"] in ("finished", "error", "stopped") else None

    final = wait_for(ended, 90, what="the cycle's end")
    assert final["state"] == "finished", final.get("error")
    part = cube(cell)
    x, y, z = part["pose"]["position"]
    assert part["held"] is False
    assert np.allclose([x, y], tcp_at(PLACE)[:2], atol=1e-3), (part, tcp_at(PLACE))
    assert z == pytest.approx(0.02)
    sensors = cell.robot.http.get("/sim/cell/sensors").json()
    assert sensors["part_present"] is False  # taken from the pick place
    state = cell.runtime.api("GET", "/devices/cell_io/state").json()
    assert state["values"]["lamp_green"] is True
