"""A simulated camera added to a test's runtime, with its simulator's own routes; placing it
in the world, and robot-origin calibration runs of the simulated UR5 it looks at."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.runtime.bench.harness.jog import Cell
from openpendant.runtime.bench.harness.processes import Runtime, wait_for
from openpendant.runtime.kit.device_auth import DeviceAuth, known_secret
from openpendant.runtime.kit.settings import DeviceSpec

YAML = {"Content-Type": "application/x-yaml"}
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


class Cam:
    """The camera added as `camera`, and its simulator's own routes (the world's side)."""

    def __init__(self, runtime: Runtime, spec: DeviceSpec) -> None:
        self.runtime = runtime
        uuid = runtime.own_device(spec)["uuid"]
        added = runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": "camera"})
        assert added.status_code in (200, 201), added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/camera").json()["status"] == "connected",
            30,
            what="the camera connected",
        )
        device = runtime.api("GET", "/devices/camera").json()
        secret = known_secret(runtime.data_dir, device["uuid"])
        self.sim = httpx.Client(
            base_url=device["url"], timeout=10, auth=DeviceAuth(secret) if secret else None
        )
        self.truth: dict[str, Any] = self.sim.get("/sim/truth").json()
        pose = self.truth["camera"]["pose"]
        self.pose = np.eye(4)
        self.pose[:3, :3] = Rotation.from_quat(pose["orientation"]).as_matrix()
        self.pose[:3, 3] = pose["position"]

    def put_board(self, pose: dict[str, Any] | None) -> None:
        answer = self.sim.put("/sim/board", json={"pose": pose})
        assert answer.status_code == 200, answer.text


def truth_yaml(cam: Cam) -> str:
    """The camera's true intrinsics as an OpenCV calibration file."""
    truth = cam.truth["camera"]
    matrix = [truth["fx"], 0, truth["cx"], 0, truth["fy"], truth["cy"], 0, 0, 1]
    return (
        "%YAML:1.0\n---\n"
        f"image_width: {truth['width']}\nimage_height: {truth['height']}\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        f"   data: {matrix}\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
        f"   data: {truth['distortion']}\n"
    )


def board_on_table() -> dict[str, list[float]]:
    """The board lying face up with its centre under the camera (its first corner at
    x 225 mm, y 150 mm: the board's y runs down its rows, the world's y the other way)."""
    board = Rotation.from_euler("x", 180, degrees=True)
    at = np.array([0.45, 0.0, 0.0]) - board.apply([0.225, 0.15, 0.0])
    return {"position": at.tolist(), "orientation": board.as_quat().tolist()}


def place_the_camera(cam: Cam) -> None:
    """Its true intrinsics imported (their calibration is tested on its own), and its pose
    in the world calibrated from the board on the table."""
    runtime = cam.runtime
    imported = runtime.api(
        "PUT",
        "/vision/cameras/camera/calibration.yaml",
        content=truth_yaml(cam).encode(),
        headers=YAML,
    )
    assert imported.status_code == 200, imported.text
    on_table = board_on_table()
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
