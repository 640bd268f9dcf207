"""The Scene panel by touch: preview the path to a waypoint (clear), add a box and place it
on that path (the preview turns red and names the box), nudge it, delete it (clear again);
the closest distance shows; the 3D view draws the box and the colliding path."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import BrowserContext, expect

from runtime.bench.harness.processes import Runtime, wait_for
from runtime.robotics.kinematics import Kinematics
from runtime.robotics.robot_info import load_robot_info
from tests.browser.conftest import PageErrors, add_robot, fits_the_screen
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
