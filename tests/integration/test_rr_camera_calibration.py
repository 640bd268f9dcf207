"""An RR standard camera calibrated through the runtime (issue 35, must-show 3): the
rr-camera driver serving a Robot Raconteur camera (tests/support/rr_sim_camera.py, the
simulated camera's renders of a ChArUco board) is added to a runtime, and the vision
service's guided intrinsic session runs on it to completion, the board moved between
captures as a person would move it; what it finds is measured against the camera's truth.
(The Vision panel drives this same session: browser/test_vision_panel.py.)"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import RobotRaconteur as RR
from scipy.spatial.transform import Rotation

from openpendant.plugins.robotraconteur.node import Node
from openpendant.runtime.bench.harness.processes import (
    DriverProc,
    Runtime,
    free_port,
    stop_all,
    wait_for,
)
from openpendant.runtime.bench.harness.views import board_views, in_world
from tests.integration.test_vision_calibration import BOARD, SIZE, finished

REPOSITORY = Path(__file__).resolve().parents[2]


class Served:
    """The RR camera's process, and an RR client of the test's own to move its board."""

    def __init__(self) -> None:
        port = free_port()
        self.url = f"rr+tcp://127.0.0.1:{port}?service=camera"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.support.rr_sim_camera", str(port), "board"],
            cwd=REPOSITORY,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "ROBOTRACONTEUR_TCP_SERVER_REUSEADDR": "1"},
        )
        assert self.proc.stdout is not None
        assert self.proc.stdout.readline().strip() == "READY"
        self.node = Node()
        self.client = self.node.connect(self.url)
        self.truth: dict[str, Any] = json.loads(self.client.getf_param("truth").data)
        pose = self.truth["pose"]
        self.pose = np.eye(4)
        self.pose[:3, :3] = Rotation.from_quat(pose["orientation"]).as_matrix()
        self.pose[:3, 3] = pose["position"]

    def put_board(self, pose: dict[str, Any] | None) -> None:
        self.client.setf_param("board", RR.VarValue(json.dumps(pose), "string"))

    def stop(self) -> None:
        self.node.close()
        self.proc.terminate()
        self.proc.wait(10)


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Runtime, Served]]:
    home = tmp_path_factory.mktemp("rr-vision")
    served = Served()
    runtime = Runtime(home, extra=["--no-sim"])
    driver = DriverProc(home, "rr-camera", "rr-cam", "--url", served.url, "--fps", "5")
    try:
        runtime.wait_ready()
        url = driver.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "camera"})
        assert added.status_code in (200, 201), added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/camera").json()["status"] == "connected",
            30,
            what="the RR camera connected",
        )
        yield runtime, served
    finally:
        stop_all([driver, runtime])
        served.stop()
    assert runtime.service_errors() == []


def test_the_guided_intrinsic_calibration_runs_on_an_rr_camera(
    cell: tuple[Runtime, Served],
) -> None:
    runtime, served = cell
    started = runtime.api("POST", "/vision/intrinsic", json={"camera": "camera", "board": BOARD})
    assert started.status_code == 201, started.text
    path = f"/vision/intrinsic/{started.json()['id']}"
    served.put_board(None)
    empty = runtime.api("POST", f"{path}/capture", timeout=30).json()
    assert not empty["accepted"] and empty["reason"] == "no board in view"
    for pose in board_views(served.truth, SIZE, 14):
        served.put_board(in_world(served.pose, pose))
        report = runtime.api("POST", f"{path}/capture", timeout=30).json()
        assert report["accepted"], report
    view = runtime.api("GET", path).json()
    assert len(view["frames"]) == 14 and view["coverage"]["ready"], view["coverage"]["hints"]
    assert (view["width"], view["height"]) == (1280, 800)

    solving = runtime.api("POST", f"{path}/solve")
    assert solving.status_code == 202, solving.text
    status = finished(runtime, solving.json())
    found, truth = status["result"], served.truth
    assert found["rms"] <= 0.3
    assert found["intrinsics"]["fx"] == pytest.approx(truth["fx"], rel=0.005)
    assert found["intrinsics"]["fy"] == pytest.approx(truth["fy"], rel=0.005)
    assert found["intrinsics"]["cx"] == pytest.approx(truth["cx"], abs=3.0)
    assert found["intrinsics"]["cy"] == pytest.approx(truth["cy"], abs=3.0)
    assert found["intrinsics"]["distortion"][0] == pytest.approx(truth["distortion"][0], abs=0.01)
    saved = runtime.api("POST", f"/vision/operations/{status['id']}/save")
    assert saved.status_code == 200, saved.text
    stored = runtime.api("GET", "/vision/cameras/camera/calibration").json()
    assert stored["intrinsics"] == found["intrinsics"]
