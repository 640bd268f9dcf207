"""The Scene panel by touch: preview the path to a waypoint (clear), add a box and place it
on that path (the preview turns red and names the box), nudge it, delete it (clear again);
the closest distance shows; the 3D view draws the box and the colliding path, and every robot
of the cell where the motion service has it (the one not in focus faint)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import BrowserContext, Locator, expect

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, wait_for
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.robotics.kinematics import Kinematics, pose_to_se3
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.browser.conftest import (
    PageErrors,
    add_robot,
    fits_the_screen,
    robot_joints,
    robot_state,
)
from tests.support.png import decode

INFO = load_robot_info("ur5")
LEFT = [1.0, -1.0, 1.8, -2.37, -1.57, 0.0]
RIGHT = [-1.0, -1.0, 1.8, -2.37, -1.57, 0.0]


@pytest.fixture(scope="module")
def robot(runtime: Runtime) -> str:
    add_robot(runtime)
    token = runtime.api("POST", "/devices/robot/lease", json={"holder": "setup"}).json()["token"]
    headers = {"X-Lease-Token": token}
    assert runtime.api("POST", "/jog/robots/robot/enable", headers=headers).status_code == 200
    moved = runtime.api(
        "POST",
        "/motion/robots/robot/moves",
        params={"wait": 30},
        json={"kind": "joint", "target": {"joints": LEFT}, "speed": 1.0},
        headers=headers,
    )
    assert moved.json()["state"] == "finished", moved.text
    runtime.api("DELETE", "/devices/robot/lease", headers=headers)
    for name, joints in (("left", LEFT), ("right", RIGHT)):
        runtime.api(
            "PUT",
            f"/variables/{name}",
            json={"type": "joint_waypoint", "value": {"joints": joints, "robot": "robot"}},
        )
    return "robot"


def red_pixels(png: bytes) -> int:
    """The colliding path and its contact marker are drawn in the UI's red (#f85149)."""
    image = decode(png)[:, :, :3].astype(int)
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return int(((r > 180) & (g < 120) & (b < 120)).sum())


def stored(runtime: Runtime, name: str) -> dict[str, Any]:
    response = runtime.api("GET", f"/variables/{name}")
    assert response.status_code == 200, response.text
    value: dict[str, Any] = response.json()["value"]
    return value


def test_a_box_on_the_path_turns_the_preview_red(
    runtime: Runtime, robot: str, tablet: BrowserContext, artifacts: Path
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/scene")
    view = page.get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)

    # The path to "right" is clear while the scene is empty.
    page.get_by_test_id("preview-target").select_option("right")
    preview = page.get_by_test_id("preview")
    expect(preview).to_have_attribute("data-state", "ok", timeout=20_000)
    expect(page.get_by_test_id("clearance")).to_contain_text("Nothing near")

    # Add a box by touch; it is stored as a scene object and selected for editing.
    page.get_by_test_id("add-box").tap()
    box = page.locator("[data-testid=scene-object][data-name=box_1]")
    expect(box).to_have_attribute("aria-pressed", "true")
    assert stored(runtime, "box_1")["shape"] == "box"

    # Put it where the arm passes halfway: the preview turns red and names the box.
    halfway = Kinematics(INFO).tcp((np.array(LEFT) + np.array(RIGHT)) / 2).translation
    for axis, value in zip("xyz", halfway, strict=True):
        field = page.get_by_test_id(f"pos-{axis}")
        field.fill(str(round(value * 1000)))
        field.dispatch_event("change")
    page.get_by_test_id("apply").tap()
    expect(preview).to_have_attribute("data-state", "collision", timeout=20_000)
    expect(preview).to_contain_text("box_1")
    assert np.allclose(stored(runtime, "box_1")["pose"]["position"], halfway, atol=0.001)
    page.wait_for_timeout(500)  # a software frame is drawn at most every 200 ms
    page.screenshot(path=artifacts / "1-scene-collision.png")
    assert red_pixels(view.screenshot(path=artifacts / "2-view-collision.png")) > 30
    # With the box near the arm's path, but not at the robot: a distance is shown.
    expect(page.get_by_test_id("clearance")).to_contain_text("Closest:", timeout=5_000)

    # Nudge it up 1 cm with a tap.
    z = stored(runtime, "box_1")["pose"]["position"][2]
    page.get_by_test_id("nudge-z-plus").tap()
    wait_for(
        lambda: abs(stored(runtime, "box_1")["pose"]["position"][2] - (z + 0.01)) < 1e-9,
        5,
        what="the box raised 10 mm",
    )

    # Delete it (a second tap confirms): the path is clear again.
    page.get_by_test_id("delete").tap()
    expect(page.get_by_test_id("delete")).to_contain_text("Tap again")
    page.get_by_test_id("delete").tap()
    expect(box).to_have_count(0)
    expect(preview).to_have_attribute("data-state", "ok", timeout=20_000)
    assert runtime.api("GET", "/variables/box_1").status_code == 404
    assert errors.errors == []


def test_the_scene_panel_fits_a_phone(runtime: Runtime, robot: str, phone: BrowserContext) -> None:
    page = phone.new_page()
    page.goto(f"{runtime.url}/#/scene")
    expect(page.get_by_test_id("add-box")).to_be_visible()
    assert fits_the_screen(page)


# The Panda stands 1.5 m beside the UR5, turned a quarter turn.
PANDA_BASE = {
    "position": [1.5, 0.3, 0.0],
    "orientation": [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)],
}


@pytest.fixture
def panda(runtime: Runtime, robot: str, tmp_path: Path) -> Iterator[str]:
    """A second robot of the cell, on its own base."""
    frame = {"type": "frame", "value": {"pose": PANDA_BASE}}
    assert runtime.api("PUT", "/variables/frames.panda", json=frame).is_success
    sim = SimRobotProc(tmp_path, name="scene-panda", model="panda")
    sim.wait_ready()
    try:
        wait_for(lambda: runtime.is_detected(sim.uuid), 10, what="the Panda detected")
        paired = {"uuid": sim.uuid, "local_name": "panda", "pairing": sim.secret}
        added = runtime.api("POST", "/devices", json=paired)
        assert added.status_code == 201, added.text
        wait_for(
            lambda: runtime.api("GET", "/devices/panda").json()["status"] == "connected",
            10,
            what="the Panda connected",
        )
        yield "panda"
    finally:
        runtime.api("DELETE", "/devices/panda")
        runtime.api("DELETE", "/variables/frames.panda")
        sim.stop()


class DrawnCell:
    """What the 3D view says it draws of each robot (its read-only test hook)."""

    def __init__(self, view: Locator, runtime: Runtime) -> None:
        self.view = view
        self.runtime = runtime
        self.last: Any = None
        self.kinematics: dict[str, Kinematics] = {}

    def placed(self, name: str) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
        """Where the motion service has the robot's base and flange (world frame, metres)."""
        scene = self.runtime.api("GET", "/motion/scene").json()
        base = pose_to_se3(Pose.model_validate(scene["robots"][name]["base"]))
        if name not in self.kinematics:
            info = self.runtime.api("GET", f"/jog/robots/{name}").json()["info"]
            self.kinematics[name] = Kinematics(RobotInfo.model_validate(info))
        flange = base * self.kinematics[name].flange(robot_joints(self.runtime, name))
        return base.translation, flange.translation

    def drawn(self) -> dict[str, dict[str, Any]]:
        robots = self.view.evaluate("e => e.getRootNode().host.drawnRobots()")
        self.last = robots
        return {r["name"]: r for r in robots}

    def shows(self, dimmed: dict[str, bool]) -> bool:
        """Exactly these robots, each on its base at its joints, faint as `dimmed` says."""
        drawn = self.drawn()
        if set(drawn) != set(dimmed):
            return False
        for name, faint in dimmed.items():
            base, flange = self.placed(name)
            robot = drawn[name]
            if robot["dimmed"] != faint or len(robot["flange"]) != 3:
                return False
            if not np.allclose(robot["base"], base, atol=0.002):
                return False
            if not np.allclose(robot["flange"], flange, atol=0.002):
                return False
        return True

    def wait(self, dimmed: dict[str, bool], what: str) -> None:
        try:
            wait_for(lambda: self.shows(dimmed), 20, interval=0.2, what=what)
        except TimeoutError as exc:
            raise AssertionError(f"{exc}; drawn: {self.last}") from exc


def move_joints(runtime: Runtime, name: str, joints: list[float]) -> None:
    token = runtime.api("POST", f"/devices/{name}/lease", json={"holder": "setup"}).json()["token"]
    headers = {"X-Lease-Token": token}
    try:
        assert runtime.api("POST", f"/jog/robots/{name}/enable", headers=headers).status_code == 200
        wait_for(lambda: robot_state(runtime, name)["flags"]["ready"], 10, what=f"{name} ready")
        moved = runtime.api(
            "POST",
            f"/motion/robots/{name}/moves",
            params={"wait": 30},
            json={"kind": "joint", "target": {"joints": joints}, "speed": 1.0},
            headers=headers,
        )
        assert moved.json().get("state") == "finished", moved.text
    finally:
        runtime.api("DELETE", f"/devices/{name}/lease", headers=headers)


def test_the_3d_view_draws_every_robot_of_the_cell_the_one_not_in_focus_faint(
    runtime: Runtime, robot: str, panda: str, tablet: BrowserContext, artifacts: Path
) -> None:
    """Issue 32: the view drew only the robot in focus while the Scene panel said it stood
    inside the other."""
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/scene")
    page.locator("[data-testid=status-robot][data-name=robot]").tap()
    view = page.get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-robot", "robot", timeout=20_000)
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    cell = DrawnCell(view, runtime)
    cell.wait({"robot": False, "panda": True}, "both robots drawn on their bases, the Panda faint")
    page.wait_for_timeout(500)  # a software frame is drawn at most every 200 ms
    view.screenshot(path=artifacts / "1-ur5-in-focus.png")

    # The Panda moves (not in focus): its drawing follows its joints.
    before = np.array(cell.drawn()["panda"]["flange"])
    target = robot_joints(runtime, panda) + np.array([0.6, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0])
    move_joints(runtime, panda, target.tolist())
    cell.wait({"robot": False, "panda": True}, "the faint Panda drawn where it moved")
    assert np.linalg.norm(np.array(cell.drawn()["panda"]["flange"]) - before) > 0.05

    # The Panda in focus: it is drawn as it is, the UR5 faint.
    page.locator("[data-testid=status-robot][data-name=panda]").tap()
    expect(view).to_have_attribute("data-robot", "panda", timeout=20_000)
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    cell.wait({"robot": True, "panda": False}, "the UR5 faint and the Panda not")
    page.wait_for_timeout(500)
    view.screenshot(path=artifacts / "2-panda-in-focus.png")

    # Mounted elsewhere (here by another client): drawn on its new base at once.
    frame = {"type": "frame", "value": {"pose": {"position": [1.2, -0.4, 0.1]}}}
    assert runtime.api("PUT", "/variables/frames.panda", json=frame).is_success
    cell.wait({"robot": True, "panda": False}, "the Panda drawn on its new base")
    assert np.allclose(cell.drawn()["panda"]["base"], [1.2, -0.4, 0.1], atol=0.002)
    assert errors.errors == []
