"""Robot-origin calibration through the runtime (issue 17): the simulated camera above the
cell sees the tag on the simulated UR5's flange; the vision service moves the robot through
generated poses under the test's control lease and finds where its base stands in the
world, within 1 mm and 0.1° of the simulation's truth, from 12 poses. Then the robot is set
down 5 cm away in the simulation, and the run finds it there.

Not `concurrent`: the robot moves in real time."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from runtime.bench.harness.jog import Cell
from runtime.bench.harness.processes import Runtime, child_env, wait_for
from runtime.kit.settings import DeviceSpec, default_devices
from tests.support.vision import YAML, Cam

# A board of 50 mm squares to place the camera by: the larger the board, the better its pose
# from a camera a metre above it (a 30 mm one left the camera 1.7 mm off).
BOARD = {"squares_x": 9, "squares_y": 6, "square": 0.05, "marker": 0.037}
CAMERA_SPEC = DeviceSpec(
    driver="sim-camera",
    name="sim-cam",
    options={"noise": 1.0, "fps": 20, "cell": "sim-ur5", "square": 0.05, "marker": 0.037},
)
HOME = [0.0, -1.9, -1.2, 1.57, 1.57, 0.0]  # the flange looking up at the camera
REGION = {"centre": [0.45, 0.0, 0.45], "size": [0.16, 0.3, 0.12], "tilt": 30.0, "spin": 60.0}


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Cell, Cam]]:
    home = tmp_path_factory.mktemp("robot-origin")
    devices = json.dumps([default_devices()[0].model_dump(), CAMERA_SPEC.model_dump()])
    runtime = Runtime(home, env=child_env(home, OPENPENDANT_DEVICES=devices))
    runtime.wait_ready()
    try:
        cell = Cell(runtime)
        cam = Cam(runtime, CAMERA_SPEC)
        place_the_camera(cam)
        yield cell, cam
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


def place_the_camera(cam: Cam) -> None:
    """Its true intrinsics imported (their calibration is tested on its own), and its pose
    in the world calibrated from the board on the table."""
    truth = cam.truth["camera"]
    matrix = [truth["fx"], 0, truth["cx"], 0, truth["fy"], truth["cy"], 0, 0, 1]
    text = (
        "%YAML:1.0\n---\n"
        f"image_width: {truth['width']}\nimage_height: {truth['height']}\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        f"   data: {matrix}\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
        f"   data: {truth['distortion']}\n"
    )
    runtime = cam.runtime
    imported = runtime.api(
        "PUT", "/vision/cameras/camera/calibration.yaml", content=text.encode(), headers=YAML
    )
    assert imported.status_code == 200, imported.text
    board = Rotation.from_euler("x", 180, degrees=True)
    at = np.array([0.45, 0.0, 0.0]) - board.apply([0.225, 0.15, 0.0])
    on_table = {"position": at.tolist(), "orientation": board.as_quat().tolist()}
    cam.put_board(on_table)
    body = {
        "camera": "camera",
        "board_pose": on_table,
        "board": BOARD,
        "frames": 5,
    }
    started = runtime.api("POST", "/vision/extrinsic", json=body)
    assert started.status_code == 202, started.text
    done = finished(runtime, started.json()["id"])
    saved = runtime.api("POST", f"/vision/operations/{done['id']}/save")
    assert saved.status_code == 200, saved.text
    cam.put_board(None)


def finished(runtime: Runtime, op: str, timeout: float = 120) -> dict[str, Any]:
    def ended() -> dict[str, Any] | None:
        status: dict[str, Any] = runtime.api("GET", f"/vision/operations/{op}").json()
        return status if status["state"] != "running" else None

    status = wait_for(ended, timeout, interval=0.2, what=f"{op} to end")
    assert status["state"] == "done", status
    return status


def calibrate(cell: Cell, poses: int = 12) -> dict[str, Any]:
    cell.ready()
    cell.place(HOME)
    body = {"robot": "robot", "camera": "camera", "region": REGION, "poses": poses, "speed": 1.0}
    started = cell.runtime.api("POST", "/vision/robot_origin", json=body, headers=cell.headers())
    assert started.status_code == 202, started.text
    return finished(cell.runtime, started.json()["id"])


def off_by(pose: dict[str, Any], truth: dict[str, Any]) -> tuple[float, float]:
    mm = float(np.linalg.norm(np.subtract(pose["position"], truth["position"])) * 1000)
    turned = (
        Rotation.from_quat(pose["orientation"]) * Rotation.from_quat(truth["orientation"]).inv()
    )
    return mm, float(np.degrees(turned.magnitude()))


def test_the_robot_set_down_elsewhere_is_found_where_it_stands(cell: tuple[Cell, Cam]) -> None:
    """The runtime believes the robot stands at the world's origin (no `frames.robot`); in
    the simulation it stands 5 cm away along y, turned by 1°."""
    robot_cell, _cam = cell
    runtime = robot_cell.runtime
    refused = runtime.api(
        "POST", "/vision/robot_origin", json={"robot": "robot", "camera": "camera"}
    )
    assert refused.status_code in (401, 403, 409, 422), refused.text  # no lease: never moves
    moved = {
        "position": [0.0, 0.05, 0.0],
        "orientation": Rotation.from_euler("z", 1.0, degrees=True).as_quat().tolist(),
    }
    answer = robot_cell.robot.http.put("/sim/base", json=moved)
    assert answer.status_code == 200, answer.text

    status = calibrate(robot_cell)
    result = status["result"]
    mm, degrees = off_by(result["base"], moved)
    assert mm < 1.0 and degrees < 0.1, (mm, degrees, result)
    assert result["moved_mm"] == pytest.approx(50.0, abs=1.0)
    seen = [p for p in result["poses"] if p["seen"]]
    assert len(seen) >= 8 and len(result["poses"]) == 12
    assert all(p["residual_px"] < 0.5 for p in seen)
    assert not any(p["outlier"] for p in seen)
    assert runtime.api("GET", "/variables/frames.robot").status_code == 404  # not yet saved
    saved = runtime.api("POST", f"/vision/operations/{status['id']}/save")
    assert saved.json()["saved"] == ["frames.robot"]
    stored = runtime.api("GET", "/variables/frames.robot").json()["value"]
    assert stored["pose"] == result["base"] and stored["parent"] == "world"

    # The motion service now places the robot there.
    def placed() -> bool:
        scene = runtime.api("GET", "/motion/scene").json()
        at = scene["robots"]["robot"]["base"]["position"]
        return bool(np.allclose(at, moved["position"], atol=1e-3))

    wait_for(placed, 5, what="the motion service placing the robot where it was found")


def test_cancelling_a_run_stops_the_robot_and_stores_nothing(cell: tuple[Cell, Cam]) -> None:
    robot_cell, _cam = cell
    runtime = robot_cell.runtime
    before = runtime.api("GET", "/variables/frames.robot").json()
    robot_cell.ready()
    robot_cell.place(HOME)
    body = {"robot": "robot", "camera": "camera", "region": REGION, "poses": 12, "speed": 0.3}
    started = runtime.api("POST", "/vision/robot_origin", json=body, headers=robot_cell.headers())
    assert started.status_code == 202, started.text
    op = started.json()["id"]
    wait_for(
        lambda: not robot_cell.robot.stopped(), 30, interval=0.02, what="the robot moving to a pose"
    )
    cancelled = runtime.api("POST", f"/vision/operations/{op}/cancel").json()
    assert cancelled["state"] == "cancelled" and cancelled["result"] is None
    robot_cell.robot.wait_stopped(timeout=2.0)
    assert runtime.api("POST", f"/vision/operations/{op}/save").status_code == 409
    assert runtime.api("GET", "/variables/frames.robot").json() == before
    # The run's task has ended (cancel waits for it): nothing of it can move the robot again.
    assert runtime.api("GET", f"/vision/operations/{op}").json()["state"] == "cancelled"
