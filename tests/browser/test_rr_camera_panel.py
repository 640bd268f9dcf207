"""An RR standard camera calibrated by touch in the Vision panel (issue 35, must-show 3):
the rr-camera driver serving a Robot Raconteur camera (tests/support/rr_sim_camera.py, the
simulated camera's renders of a ChArUco board) is added to a runtime by its driver's URL;
the intrinsic wizard runs on its live picture to a stored calibration, the board moved over
RR between captures as a person would move it, and what it stored is measured against the
camera's truth."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import RobotRaconteur as RR
from playwright.sync_api import BrowserContext, expect
from scipy.spatial.transform import Rotation

from openpendant.plugins.robotraconteur.node import Node
from openpendant.runtime.bench.harness.processes import (
    DriverProc,
    Runtime,
    stop_all,
    wait_for,
)
from openpendant.runtime.bench.harness.views import board_views, in_world
from tests.browser.conftest import browser_env
from tests.browser.test_vision_panel import BOARD_SIZE, open_panel, set_number
from tests.support.rr_service import RRService


class Served:
    """The RR camera's process, and an RR client of the test's own to move its board."""

    def __init__(self) -> None:
        self.service = RRService("rr_sim_camera", "camera", "board")
        self.url = self.service.url
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
        self.service.stop()


@pytest.fixture(scope="module")
def served() -> Iterator[Served]:
    camera = Served()
    yield camera
    camera.stop()


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory, served: Served) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("rr-vision")
    proc = Runtime(home, env=browser_env(home), extra=["--no-sim"])
    driver = DriverProc(home, "rr-camera", "rr-cam", "--url", served.url, "--fps", "5")
    try:
        proc.wait_ready()
        url = driver.wait_ready()
        added = proc.api("POST", "/devices", json={"url": url, "local_name": "camera"})
        assert added.status_code in (200, 201), added.text
        wait_for(
            lambda: proc.api("GET", "/devices/camera").json()["status"] == "connected",
            30,
            what="the RR camera connected",
        )
        yield proc
    finally:
        stop_all([driver, proc])
    assert proc.service_errors() == []


def test_the_intrinsic_wizard_calibrates_an_rr_camera(
    runtime: Runtime, served: Served, tablet: BrowserContext
) -> None:
    page, errors = open_panel(tablet, runtime)
    expect(page.get_by_test_id("vision-not-calibrated")).to_be_visible()
    page.get_by_test_id("vision-step-intrinsic").tap()
    set_number(page.get_by_test_id("board-square"), "50")
    set_number(page.get_by_test_id("board-marker"), "37")
    page.get_by_test_id("board-dictionary").select_option("5x5_100")
    page.get_by_test_id("intrinsic-start").tap()
    capture = page.get_by_test_id("intrinsic-capture")
    expect(capture).to_be_enabled()

    served.put_board(None)
    capture.tap()
    report = page.get_by_test_id("capture-report")
    expect(report).to_have_attribute("data-accepted", "false")
    expect(report).to_contain_text("no board in view")

    for index, view in enumerate(board_views(served.truth, BOARD_SIZE, 11)):
        served.put_board(in_world(served.pose, view))
        capture.tap()
        expect(page.get_by_test_id(f"frame-{index}")).to_be_visible(timeout=30_000)
        expect(report).to_have_attribute("data-accepted", "true")
    expect(page.get_by_test_id("intrinsic-coverage")).to_have_attribute("data-ready", "true")

    page.get_by_test_id("intrinsic-solve").tap()
    expect(page.get_by_test_id("intrinsic-result")).to_be_visible(timeout=60_000)
    assert float(page.get_by_test_id("intrinsic-rms").inner_text().split()[0]) <= 0.3
    page.get_by_test_id("intrinsic-save").tap()
    expect(page.get_by_test_id("intrinsic-saved")).to_contain_text("calibration.camera")
    expect(page.get_by_test_id("vision-calibrated")).to_be_visible()
    stored = runtime.api("GET", "/variables/calibration.camera").json()["value"]["intrinsics"]
    truth = served.truth
    assert stored["fx"] == pytest.approx(truth["fx"], rel=0.005)
    assert stored["fy"] == pytest.approx(truth["fy"], rel=0.005)
    assert stored["cx"] == pytest.approx(truth["cx"], abs=3.0)
    assert stored["cy"] == pytest.approx(truth["cy"], abs=3.0)
    assert stored["distortion"][0] == pytest.approx(truth["distortion"][0], abs=0.01)
    served.put_board(None)
    assert errors.errors == []
