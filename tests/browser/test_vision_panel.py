"""The Vision panel by touch (issue 17), against the simulated camera above the simulated
UR5's table: the live picture; the intrinsic-calibration wizard from the board's settings to
a stored calibration, the board moved between captures as a person would move it; a
calibration file imported and the camera placed from a board at a typed pose; a template
taught by drawing a box around a part with a finger, then found; a marker detector set up
and run; the detect block's choices; the panel on a phone."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any, cast

import numpy as np
import pytest
from playwright.sync_api import BrowserContext, Locator, Page, expect
from scipy.spatial.transform import Rotation

from openpendant.runtime.bench.harness.jog import RobotView
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from openpendant.runtime.bench.harness.views import board_views, in_world
from openpendant.runtime.kit.settings import default_devices
from tests.browser.conftest import (
    BROWSER_LINK_TIMEOUT,
    Finger,
    PageErrors,
    add_robot,
    fits_the_screen,
)
from tests.support.vision import (
    CAMERA_SPEC,
    HOME,
    REGION,
    Cam,
    board_on_table,
    place_the_camera,
    truth_yaml,
)

BOARD_SIZE = (0.45, 0.30)  # the simulated camera's board here: 9 x 6 squares of 50 mm
IMAGE = (1280, 800)


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("vision-panel")
    robot = default_devices()[0]
    env = child_env(
        home,
        OPENPENDANT_DEVICES=json.dumps([robot.model_dump(), CAMERA_SPEC.model_dump()]),
        OPENPENDANT_LINK__STALE_AFTER=str(BROWSER_LINK_TIMEOUT),
        OPENPENDANT_LINK__DRIVER_TIMEOUT=str(BROWSER_LINK_TIMEOUT),
    )
    proc = Runtime(home, env=env)
    proc.wait_ready()
    yield proc
    proc.stop()
    assert proc.service_errors() == []


@pytest.fixture(scope="module")
def cam(runtime: Runtime) -> Cam:
    return Cam(runtime, CAMERA_SPEC)


def open_panel(context: BrowserContext, runtime: Runtime) -> tuple[Page, PageErrors]:
    page = context.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/vision")
    # The live picture: frames arrive and are drawn.
    expect(page.get_by_test_id("camera-canvas")).to_be_visible(timeout=15_000)
    expect(page.locator("op-camera-view")).to_have_attribute(
        "data-frames", re.compile(r"^[1-9]"), timeout=15_000
    )
    return page, errors


def set_number(field: Locator, value: str) -> None:
    field.fill(value)
    field.blur()


def test_the_intrinsic_wizard_calibrates_the_camera_and_stores_it(
    runtime: Runtime, cam: Cam, tablet: BrowserContext
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

    # Nothing in view: refused with the reason.
    cam.put_board(None)
    capture.tap()
    report = page.get_by_test_id("capture-report")
    expect(report).to_have_attribute("data-accepted", "false")
    expect(report).to_contain_text("no board in view")
    expect(page.get_by_test_id("intrinsic-hints")).to_contain_text("Hold the board")

    views = board_views(cam.truth["camera"], BOARD_SIZE, 11)
    for index, view in enumerate(views):
        cam.put_board(in_world(cam.pose, view))
        capture.tap()
        expect(page.get_by_test_id(f"frame-{index}")).to_be_visible(timeout=30_000)
        expect(report).to_have_attribute("data-accepted", "true")
    # A frame dropped is gone from the list and the map; the same view is taken again.
    page.get_by_test_id(f"frame-drop-{len(views) - 1}").tap()
    expect(page.get_by_test_id(f"frame-{len(views) - 1}")).to_have_count(0)
    capture.tap()
    expect(page.get_by_test_id(f"frame-{len(views) - 1}")).to_be_visible(timeout=30_000)
    expect(page.get_by_test_id("intrinsic-coverage")).to_have_attribute("data-ready", "true")

    page.get_by_test_id("intrinsic-solve").tap()
    result = page.get_by_test_id("intrinsic-result")
    expect(result).to_be_visible(timeout=60_000)
    rms = float(page.get_by_test_id("intrinsic-rms").inner_text().split()[0])
    assert rms <= 0.3
    # Each frame shows its own error after the solve.
    expect(page.get_by_test_id("frame-0")).to_contain_text(" px")

    stored_before = runtime.api("GET", "/variables/calibration.camera")
    assert stored_before.status_code == 404  # nothing is stored until Save
    page.get_by_test_id("intrinsic-save").tap()
    expect(page.get_by_test_id("intrinsic-saved")).to_contain_text("calibration.camera")
    expect(page.get_by_test_id("vision-calibrated")).to_be_visible()
    stored = runtime.api("GET", "/variables/calibration.camera").json()
    truth = cam.truth["camera"]
    assert stored["type"] == "camera_calibration"
    assert stored["value"]["intrinsics"]["fx"] == pytest.approx(truth["fx"], rel=0.005)
    assert stored["value"]["intrinsics"]["fy"] == pytest.approx(truth["fy"], rel=0.005)
    board = runtime.api("GET", "/variables/vision.board").json()["value"]
    assert (board["square"], board["marker"]) == pytest.approx((0.05, 0.037))
    cam.put_board(None)
    assert errors.errors == []


def test_the_camera_is_placed_from_an_imported_calibration_and_a_board_typed_in(
    runtime: Runtime, cam: Cam, tablet: BrowserContext, tmp_path: Path
) -> None:
    """OpenCV's file imported with the panel's button; the board laid on the table at a
    pose typed in the panel (mm and degrees); the camera's pose found and saved."""
    board = {"squares_x": 9, "squares_y": 6, "square": 0.05, "marker": 0.037}
    setting = {"type": "calibration_board", "value": {**board, "dictionary": "5x5_100"}}
    assert runtime.api("PUT", "/variables/vision.board", json=setting).status_code == 200
    calibration = tmp_path / "camera.yaml"
    calibration.write_text(truth_yaml(cam))
    page, errors = open_panel(tablet, runtime)
    page.get_by_test_id("vision-import").set_input_files(str(calibration))
    truth = cam.truth["camera"]["fx"]

    def imported() -> bool:
        stored = runtime.api("GET", "/variables/calibration.camera").json()
        return bool(stored["value"]["intrinsics"]["fx"] == pytest.approx(truth))

    wait_for(imported, 10, what="the file's calibration stored")
    expect(page.get_by_test_id("vision-calibrated")).to_contain_text("(0.00 px)")

    on_table = board_on_table()
    cam.put_board(on_table)
    page.get_by_test_id("vision-step-placement").tap()
    x, y, z = (round(v * 1000) for v in on_table["position"])
    for field, value in (("x", x), ("y", y), ("z", z), ("roll", 180), ("pitch", 0), ("yaw", 0)):
        set_number(page.get_by_test_id(f"board-{field}"), str(value))
    page.get_by_test_id("placement-run").tap()
    expect(page.get_by_test_id("placement-result")).to_be_visible(timeout=30_000)
    page.get_by_test_id("placement-save").tap()
    expect(page.get_by_test_id("placement-saved")).to_contain_text("frames.camera")
    expect(page.get_by_test_id("vision-placed")).to_contain_text("Placed in the world")
    found = runtime.api("GET", "/variables/frames.camera").json()["value"]
    assert found["parent"] == "world"
    off = np.subtract(found["pose"]["position"], cam.pose[:3, 3])
    assert np.linalg.norm(off) < 0.002, off
    turned = Rotation.from_quat(found["pose"]["orientation"]).as_matrix().T @ cam.pose[:3, :3]
    assert np.degrees(Rotation.from_matrix(turned).magnitude()) < 0.2
    cam.put_board(None)
    assert errors.errors == []


def image_to_page(canvas: Locator, x: float, y: float) -> tuple[float, float]:
    """A point of the image on the screen: the picture is fitted into the canvas's box."""
    box = canvas.bounding_box()
    assert box is not None
    scale = min(box["width"] / IMAGE[0], box["height"] / IMAGE[1])
    left = box["x"] + (box["width"] - IMAGE[0] * scale) / 2
    top = box["y"] + (box["height"] - IMAGE[1] * scale) / 2
    return left + x * scale, top + y * scale


def part_box(runtime: Runtime, label: str) -> dict[str, Any]:
    """Where part `label`'s tag is in the image, found by an ArUco detector."""
    detector = {"method": "aruco", "camera": "camera", "dictionary": "4x4_50"}
    stored = runtime.api(
        "PUT", "/variables/detectors.tags", json={"type": "detector", "value": detector}
    )
    assert stored.status_code == 200, stored.text
    found = runtime.api("POST", "/vision/detectors/tags/detect", json={"labels": [label]}).json()
    assert len(found["detections"]) == 1, found
    box: dict[str, Any] = found["detections"][0]["box"]
    return box


def test_a_template_is_taught_by_drawing_a_box_with_a_finger(
    runtime: Runtime, cam: Cam, tablet: BrowserContext
) -> None:
    tag = part_box(runtime, "1")
    margin = 6
    want = (
        round(tag["x"] - margin),
        round(tag["y"] - margin),
        round(tag["width"] + 2 * margin),
        round(tag["height"] + 2 * margin),
    )
    page, errors = open_panel(tablet, runtime)
    page.get_by_test_id("vision-step-template").tap()
    page.get_by_test_id("template-name").fill("part_one")
    page.get_by_test_id("template-label").fill("part")
    expect(page.get_by_test_id("template-teach")).to_be_disabled()  # no box yet

    canvas = page.get_by_test_id("camera-canvas")
    x0, y0 = image_to_page(canvas, want[0], want[1])
    x1, y1 = image_to_page(canvas, want[0] + want[2], want[1] + want[3])
    finger = Finger(page)
    box = canvas.bounding_box()
    assert box is not None
    finger.down(canvas, (x0 - box["x"], y0 - box["y"]))
    for step in range(1, 11):
        finger.move(x0 + (x1 - x0) * step / 10, y0 + (y1 - y0) * step / 10)
    finger.up()
    drawn = page.get_by_test_id("template-box")
    expect(drawn).to_have_attribute("data-box", re.compile(r"^\d+,\d+,\d+,\d+$"))
    got = [int(v) for v in (drawn.get_attribute("data-box") or "").split(",")]
    scale = IMAGE[0] / box["width"]  # one screen pixel is this many of the image's
    assert all(abs(a - b) <= 2 * scale + 1 for a, b in zip(got, want, strict=True)), (got, want)

    page.get_by_test_id("template-teach").tap()
    expect(page.get_by_test_id("template-taught")).to_contain_text("detectors.part_one")
    stored = runtime.api("GET", "/variables/detectors.part_one").json()
    assert stored["type"] == "detector" and stored["value"]["method"] == "template"
    assert stored["value"]["camera"] == "camera"

    # Tried at once: the part it was taught on is found where the box was drawn.
    page.get_by_test_id("template-test").tap()
    summary = page.get_by_test_id("detect-summary")
    expect(summary).to_have_attribute("data-count", re.compile(r"^[1-9]"), timeout=30_000)
    found = runtime.api("POST", "/vision/detectors/part_one/detect", json={}).json()
    centre = (want[0] + want[2] / 2, want[1] + want[3] / 2)
    assert any(
        abs(d["box"]["x"] + d["box"]["width"] / 2 - centre[0]) < 6
        and abs(d["box"]["y"] + d["box"]["height"] / 2 - centre[1]) < 6
        for d in found["detections"]
    ), found
    assert errors.errors == []


def test_the_vision_panel_fits_a_phone(runtime: Runtime, cam: Cam, phone: BrowserContext) -> None:
    page, errors = open_panel(phone, runtime)
    page.get_by_test_id("vision-step-intrinsic").tap()
    expect(page.get_by_test_id("intrinsic-start")).to_be_visible()
    assert fits_the_screen(page)
    assert errors.errors == []


def test_a_marker_detector_is_set_up_in_the_panel_and_finds_the_parts_tags(
    runtime: Runtime, cam: Cam, tablet: BrowserContext
) -> None:
    page, errors = open_panel(tablet, runtime)
    page.get_by_test_id("detector-add").tap()
    page.get_by_test_id("detector-name").fill("cell_tags")
    page.get_by_test_id("detector-dictionary").select_option("4x4_50")
    set_number(page.get_by_test_id("detector-marker-size"), "32")
    page.get_by_test_id("detector-save").tap()
    chosen = page.get_by_test_id("detect-detector")
    expect(chosen).to_have_value("cell_tags")
    stored = runtime.api("GET", "/variables/detectors.cell_tags").json()
    assert stored["value"]["method"] == "aruco"
    assert stored["value"]["marker_size"] == pytest.approx(0.032)
    page.get_by_test_id("detect-once").tap()
    found = page.get_by_test_id("detections")
    for tag in ("1", "2", "3"):
        expect(found.locator(f"li[data-label='{tag}']")).to_have_count(1)
    # Detecting again and again until stopped, each answer drawn.
    page.get_by_test_id("detect-live").tap()
    expect(page.get_by_test_id("detect-stop")).to_be_visible()
    page.get_by_test_id("detect-stop").tap()
    expect(page.get_by_test_id("detect-live")).to_be_visible()
    assert errors.errors == []


def test_the_detect_block_offers_the_stored_detectors(
    runtime: Runtime, cam: Cam, tablet: BrowserContext
) -> None:
    """A detector taught in the Vision panel (or stored anywhere) is a choice of the
    program's detect block."""
    taught = {"method": "aruco", "camera": "camera", "dictionary": "4x4_50"}
    for name in ("tags", "taught_here"):
        stored = runtime.api(
            "PUT", f"/variables/detectors.{name}", json={"type": "detector", "value": taught}
        )
        assert stored.status_code == 200, stored.text
    block = {
        "type": "vision_detect",
        "id": "look",
        "x": 30,
        "y": 30,
        "fields": {"DETECTOR": "tags"},
    }
    workspace = {"blocks": {"languageVersion": 0, "blocks": [block]}}
    saved = runtime.api("PUT", "/programs/look", json={"workspace": workspace})
    assert saved.status_code == 200, saved.text
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    page.get_by_test_id("program-select").select_option("look")
    field = page.locator('g.blocklyDraggable[data-id="look"] .blocklyDropdownField').first
    expect(field).to_be_visible(timeout=15_000)
    menu = page.locator(".blocklyDropDownDiv .blocklyMenuItem")

    def offered() -> bool:
        # The lists are read as the panel opens: a menu opened sooner shows the block's own.
        field.tap()
        listed = all(menu.get_by_text(n, exact=True).count() == 1 for n in ("taught_here", "tags"))
        page.keyboard.press("Escape")
        return listed

    wait_for(offered, 10, what="the stored detectors offered")
    assert errors.errors == []


def test_a_robot_origin_run_moves_only_under_this_tablets_control_and_cancel_stops_it(
    runtime: Runtime, cam: Cam, tablet: BrowserContext
) -> None:
    """Run needs the tablet's control of the robot (taken on the Jog panel); the run's
    progress shows, and its Cancel stops the robot and stores nothing. (A whole run and its
    result are tested through the API in integration/test_vision_cell.py.) Last in this
    file: the arm ends over the table."""
    place_the_camera(cam)
    add_robot(runtime)
    robot = RobotView(runtime)
    robot.wait_stopped()
    assert robot.http.put("/sim/joints", json={"joints": HOME}).status_code == 200
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/vision")
    page.get_by_test_id("vision-step-origin").tap()
    expect(page.get_by_test_id("origin-robot")).to_have_value("robot")
    expect(page.get_by_test_id("origin-run")).to_be_disabled()  # no control yet
    page.get_by_test_id("nav-jog").tap()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    enable = page.get_by_test_id("enable")
    if enable.count():
        enable.tap()
    expect(page.get_by_test_id("disable")).to_be_visible()

    page.get_by_test_id("nav-vision").tap()
    page.get_by_test_id("vision-step-origin").tap()
    centres, sizes = cast(list[float], REGION["centre"]), cast(list[float], REGION["size"])
    for axis, centre, size in zip("xyz", centres, sizes, strict=True):
        set_number(page.get_by_test_id(f"origin-centre-{axis}"), str(round(centre * 1000)))
        set_number(page.get_by_test_id(f"origin-size-{axis}"), str(round(size * 1000)))
    set_number(page.get_by_test_id("origin-speed"), "30")
    page.get_by_test_id("origin-run").tap()
    expect(page.get_by_test_id("op-running")).to_be_visible()
    wait_for(lambda: not robot.stopped(), 30, what="the robot moving to the first pose")
    page.get_by_test_id("op-cancel").tap()
    expect(page.get_by_test_id("op-cancelled")).to_be_visible(timeout=10_000)
    robot.wait_stopped(2.0)
    assert runtime.api("GET", "/variables/frames.robot").status_code == 404
    assert errors.errors == []
