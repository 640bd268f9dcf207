"""What a technician on a tablet or a phone relies on: one robot in focus everywhere (a robot
added later never takes it; the one shown is the one moved), STOP and the speed override on
screen whatever is scrolled, and a swipe that starts on a jog key or the 3D view scrolls the
page and moves nothing."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from playwright.sync_api import BrowserContext, Locator, Page, expect

from openpendant.runtime.bench.harness.blocks import block, text, workspace
from openpendant.runtime.bench.harness.processes import (
    STILL,
    Runtime,
    SimRobotProc,
    SpaceMouseProc,
    wait_for,
)
from tests.browser.conftest import (
    PHONE,
    Finger,
    PageErrors,
    add_robot,
    fits_the_screen,
    robot_at_rest,
    robot_joints,
    robot_state,
)
from tests.integration.test_jog import mouse_recording

PANELS = ("jog", "program", "scene", "io", "vision", "devices", "system")


@pytest.fixture(scope="module")
def robot(runtime: Runtime) -> str:
    return add_robot(runtime)


@pytest.fixture
def panda(runtime: Runtime, robot: str, tmp_path: Path) -> Iterator[SimRobotProc]:
    """A second robot, started and announced; the test adds it when it wants."""
    sim = SimRobotProc(tmp_path, name="cell-2-panda", model="panda")
    sim.wait_ready()
    try:
        yield sim
    finally:
        runtime.api("DELETE", "/devices/panda")
        sim.stop()


def chip(page: Page, name: str) -> Locator:
    return page.locator(f"[data-testid=status-robot][data-name={name}]")


def take_control_and_enable(page: Page) -> None:
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    enable = page.get_by_test_id("enable")
    if enable.count():
        enable.tap()
    expect(page.get_by_test_id("disable")).to_be_visible()


def hold(page: Page, axis: int, seconds: float) -> None:
    finger = Finger(page)
    finger.down(page.locator(f"[data-testid=jog-row][data-axis='{axis}'] [data-testid=jog-plus]"))
    time.sleep(seconds)
    finger.up()


def in_viewport(page: Page, target: Locator) -> bool:
    box = target.bounding_box()
    size = page.viewport_size
    assert size is not None
    return (
        box is not None
        and box["y"] >= 0
        and box["x"] >= 0
        and box["y"] + box["height"] <= size["height"]
        and box["x"] + box["width"] <= size["width"]
    )


def scroll_to_bottom(page: Page) -> int:
    """The panel area scrolled as far as it goes; how far that was (px)."""
    scrolled: int = page.evaluate(
        """() => {
            const main = document.querySelector('op-app').shadowRoot.querySelector('main');
            main.scrollTo(0, main.scrollHeight);
            return main.scrollTop;
        }"""
    )
    return scrolled


def scroll_top(page: Page) -> int:
    top: int = page.evaluate(
        "() => document.querySelector('op-app').shadowRoot.querySelector('main').scrollTop"
    )
    return top


def test_the_robot_in_focus_is_the_one_shown_and_moved(
    runtime: Runtime, robot: str, panda: SimRobotProc, tablet: BrowserContext, artifacts: Path
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    expect(chip(page, "robot")).to_have_attribute("aria-pressed", "true")
    expect(page.get_by_test_id("jog-robot")).to_have_text("robot")
    take_control_and_enable(page)

    # A second robot is added (elsewhere): the focus stays where the user put it. It stands
    # 2 m away (at the origin it would stand inside the UR5, and avoidance holds both).
    frame = {"type": "frame", "value": {"pose": {"position": [2.0, 0.0, 0.0]}}}
    assert runtime.api("PUT", "/variables/frames.panda", json=frame).is_success
    paired = {"uuid": panda.uuid, "local_name": "panda", "pairing": panda.secret}
    added = runtime.api("POST", "/devices", json=paired)
    assert added.status_code == 201, added.text
    expect(chip(page, "panda")).to_be_visible(timeout=10_000)
    expect(chip(page, "panda")).to_have_attribute("aria-pressed", "false")
    expect(chip(page, "robot")).to_have_attribute("aria-pressed", "true")
    expect(page.get_by_test_id("jog-robot")).to_have_text("robot")
    page.screenshot(path=artifacts / "1-second-robot-added.png")

    # The robot shown is the robot that moves.
    ur5, other = robot_joints(runtime, "robot"), robot_joints(runtime, "panda")
    hold(page, 0, 0.6)
    wait_for(lambda: robot_at_rest(runtime, "robot"), 5, what="the UR5 stopped")
    assert robot_joints(runtime, "robot")[0] > ur5[0] + 0.01
    assert np.abs(robot_joints(runtime, "panda") - other).max() < STILL

    # Focus the Panda by a tap: every panel, the 3D view and the jog keys follow.
    chip(page, "panda").tap()
    expect(chip(page, "panda")).to_have_attribute("aria-pressed", "true")
    expect(page.get_by_test_id("jog-robot")).to_have_text("panda")
    expect(page.get_by_test_id("jog-row")).to_have_count(7)
    view = page.get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-robot", "panda", timeout=20_000)
    take_control_and_enable(page)
    ur5, other = robot_joints(runtime, "robot"), robot_joints(runtime, "panda")
    hold(page, 0, 0.6)
    wait_for(lambda: robot_at_rest(runtime, "panda"), 5, what="the Panda stopped")
    assert robot_joints(runtime, "panda")[0] > other[0] + 0.01
    assert np.abs(robot_joints(runtime, "robot") - ur5).max() < STILL
    page.get_by_test_id("nav-program").tap()
    expect(page.get_by_test_id("run-robot")).to_have_text("runs on panda")
    page.get_by_test_id("nav-jog").tap()
    page.get_by_test_id("control").tap()  # hand the Panda back
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    chip(page, "robot").tap()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert errors.errors == []


@pytest.mark.parametrize("device", ["tablet", "phone"])
def test_stop_and_the_speed_override_stay_on_screen_on_every_panel(
    runtime: Runtime, robot: str, device: str, request: pytest.FixtureRequest
) -> None:
    context: BrowserContext = request.getfixturevalue(device)
    page = context.new_page()
    page.goto(f"{runtime.url}/#/jog")
    expect(page.get_by_test_id("jog-robot")).to_be_visible()
    for panel in PANELS:
        page.get_by_test_id(f"nav-{panel}").tap()
        page.wait_for_timeout(300)
        scroll_to_bottom(page)
        page.wait_for_timeout(100)
        for part in ("safety-stop", "speed", "status-robot"):
            assert in_viewport(page, page.get_by_test_id(part).first), (panel, part)
    # STOP halts the robot, whoever moves it.
    page.get_by_test_id("nav-jog").tap()
    take_control_and_enable(page)
    finger = Finger(page)
    finger.down(page.locator("[data-testid=jog-row][data-axis='5'] [data-testid=jog-plus]"))
    try:
        wait_for(lambda: not robot_at_rest(runtime), 5, what="J6 moving")
        page.get_by_test_id("safety-stop").tap()
        wait_for(lambda: robot_at_rest(runtime), 2, what="halted by STOP")
    finally:
        finger.up()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def test_a_swipe_that_starts_on_a_jog_key_or_the_view_scrolls_and_moves_nothing(
    runtime: Runtime, robot: str, phone: BrowserContext
) -> None:
    page = phone.new_page()
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    key = page.locator("[data-testid=jog-row][data-axis='4'] [data-testid=jog-plus]")
    key.scroll_into_view_if_needed()
    page.wait_for_timeout(200)
    before = robot_joints(runtime)
    finger = Finger(page)
    for target in (key, page.get_by_test_id("robot-view")):
        target.scroll_into_view_if_needed()
        page.wait_for_timeout(200)
        top = scroll_top(page)
        box = target.bounding_box()
        assert box is not None
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        finger.down(target)
        for step in range(1, 9):  # a quick flick upwards, as a thumb scrolls
            finger.move(x, y - 25 * step)
            page.wait_for_timeout(8)
        finger.up()
        page.wait_for_timeout(600)
        assert scroll_top(page) != top, "the page did not scroll"
    assert np.abs(robot_joints(runtime) - before).max() < STILL
    assert robot_at_rest(runtime)
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def test_pause_stops_the_move_on_its_path_and_resume_finishes_it(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    far = [1.5, -1.2, 1.3, -1.6, -1.57, 0.8]
    degrees = [round(float(np.degrees(v)), 6) for v in far]
    source = f"set_speed(40)\nmove_joint({degrees!r})\nprint('there')"
    saved = runtime.api("PUT", "/programs/pausing", json={"python": source})
    assert saved.status_code == 200, saved.text
    page = tablet.new_page()
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    page.get_by_test_id("nav-program").tap()
    page.get_by_test_id("program-select").select_option("pausing")
    page.get_by_test_id("run").tap()
    wait_for(lambda: not robot_at_rest(runtime), 20, what="the robot moving")
    time.sleep(0.3)
    asked = time.monotonic()
    page.get_by_test_id("pause").tap()
    # A controlled stop on the path at once, not at the end of the move.
    wait_for(lambda: robot_at_rest(runtime), 3, what="the robot stopped by pause")
    stopped_after = time.monotonic() - asked
    expect(page.get_by_test_id("run-state")).to_have_text("paused")
    held = robot_joints(runtime)
    time.sleep(0.5)
    assert np.abs(robot_joints(runtime) - held).max() < STILL
    assert np.abs(held - np.array(far)).max() > 0.2
    assert stopped_after < 2.0, f"{stopped_after:.2f} s to stop"
    page.get_by_test_id("resume").tap()
    expect(page.get_by_test_id("run-state")).to_have_text("finished", timeout=60_000)
    assert np.abs(robot_joints(runtime) - np.array(far)).max() < 1e-4
    page.get_by_test_id("nav-jog").tap()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def test_a_program_with_an_empty_input_or_a_loose_block_shows_them_and_does_not_run(
    runtime: Runtime, robot: str, tablet: BrowserContext, artifacts: Path
) -> None:
    empty_if = block("controls_if", None, DO0=block("text_print", None, TEXT=text("x")))
    stray = block("text_print", None, TEXT=text("stray"))
    stray["x"], stray["y"] = 40, 400
    ws = workspace(empty_if, stray)
    saved = runtime.api("PUT", "/programs/unfinished", json={"workspace": ws})
    assert saved.status_code == 200, saved.text
    page = tablet.new_page()
    page.goto(f"{runtime.url}/#/program")
    page.get_by_test_id("program-select").select_option("unfinished")
    items = page.get_by_test_id("problem-item")
    expect(items).to_have_count(2, timeout=10_000)
    expect(items.first).to_contain_text("the condition is empty")
    expect(items.nth(1)).to_contain_text("not part of the program")
    expect(page.get_by_test_id("run")).to_be_disabled()
    for problem in (empty_if, stray):  # the blocks themselves carry the warning
        warned = page.locator(f'g.blocklyDraggable[data-id="{problem["id"]}"] .blocklyWarningIcon')
        expect(warned).to_have_count(1)
    items.first.tap()
    expect(page.locator(f'g.blocklySelected[data-id="{empty_if["id"]}"]')).to_have_count(1)
    page.get_by_test_id("tab-python").tap()
    expect(page.get_by_test_id("python")).to_contain_text("if False:")
    expect(page.get_by_test_id("python")).not_to_contain_text("at_block")
    page.screenshot(path=artifacts / "problems.png")


def test_a_robot_added_inside_another_is_reported_then_mounted_elsewhere_and_jogged(
    runtime: Runtime, robot: str, panda: SimRobotProc, tablet: BrowserContext, artifacts: Path
) -> None:
    runtime.api("DELETE", "/variables/frames.panda")  # added at the world origin: in the UR5
    paired = {"uuid": panda.uuid, "local_name": "panda", "pairing": panda.secret}
    added = runtime.api("POST", "/devices", json=paired)
    assert added.status_code == 201, added.text
    page = tablet.new_page()
    page.goto(f"{runtime.url}/#/jog")
    expect(chip(page, "panda")).to_be_visible(timeout=10_000)
    chip(page, "panda").tap()
    expect(page.get_by_test_id("jog-robot")).to_have_text("panda")
    # Reported, with the reason: it stands inside the other robot.
    expect(page.get_by_test_id("clearance")).to_contain_text("Inside robot", timeout=10_000)
    take_control_and_enable(page)
    # A joint whose motion the overlap holds back says so, instead of "Moving" (which joints
    # those are depends on how the two arms stand inside each other).
    finger = Finger(page)
    said = ""
    for axis in range(4):
        key = f"[data-testid=jog-row][data-axis='{axis}'] [data-testid=jog-plus]"
        finger.down(page.locator(key))
        try:
            deadline = time.monotonic() + 2.0
            while time.monotonic() < deadline and "held back" not in said:
                said = page.get_by_test_id("deadman").inner_text()
                page.wait_for_timeout(50)
            if "held back" in said:
                page.screenshot(path=artifacts / "1-held-back.png")
        finally:
            finger.up()
        if "held back" in said:
            break
    assert "Not moving: held back" in said and "robot/" in said, said

    # Mounted 1.5 m away on the cell setup (Scene) screen, it jogs.
    page.get_by_test_id("nav-scene").tap()
    page.get_by_test_id("mount-x").fill("1500")
    page.get_by_test_id("mount-x").dispatch_event("change")
    page.get_by_test_id("save-mount").tap()
    expect(page.get_by_test_id("mount-x")).to_have_value("1500")
    frame = runtime.api("GET", "/variables/frames.panda").json()
    assert abs(frame["value"]["pose"]["position"][0] - 1.5) < 1e-9
    page.get_by_test_id("nav-jog").tap()
    expect(page.get_by_test_id("clearance")).not_to_contain_text("Inside", timeout=10_000)
    before = robot_joints(runtime, "panda")
    hold(page, 0, 0.8)
    wait_for(lambda: robot_at_rest(runtime, "panda"), 5, what="the Panda stopped")
    assert robot_joints(runtime, "panda")[0] > before[0] + 0.01
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def added_mouse(
    runtime: Runtime, tmp_path: Path, name: str, rest: float
) -> tuple[SpaceMouseProc, Path]:
    """A 3D mouse whose recording lifts the cap for 0.6 s, then rests `rest` s (and stays
    silent at rest: nothing to halt), added to the runtime as `mouse` with its pairing code;
    and its recording (to start it again)."""
    recording = mouse_recording(
        tmp_path / "lift.jsonl",
        [(0.6, [0, 0, -300, 0, 0, 0], 0), (rest, [0, 0, 0, 0, 0, 0], 0)],
        end="stuck",
    )
    mouse = SpaceMouseProc(tmp_path, name, recording)
    mouse.wait_ready()
    try:
        wait_for(lambda: runtime.is_detected(mouse.uuid), 10, what="mouse detected")
        paired = {"uuid": mouse.uuid, "local_name": "mouse", "pairing": mouse.secret}
        added = runtime.api("POST", "/devices", json=paired)
        assert added.status_code == 201, added.text
    except BaseException:
        mouse.stop()
        raise
    return mouse, recording


def test_the_3d_mouse_follows_the_frame_buttons_and_shows_its_axes(
    runtime: Runtime, robot: str, phone: BrowserContext, tmp_path: Path, artifacts: Path
) -> None:
    """Switched on in Joints and then set to Base, a lift raises the tool (in Joints it would
    turn joint 3); at rest the mouse says so; each axis shows live what it drives; the halt
    banner (the mouse unplugged) stays on the screen."""
    mouse, _ = added_mouse(runtime, tmp_path, "ui-mouse", rest=0.5)
    try:
        page = phone.new_page()
        page.goto(f"{runtime.url}/#/jog")
        take_control_and_enable(page)
        page.get_by_test_id("mode-joint").tap()
        toggle = page.get_by_test_id("mouse-toggle")
        expect(toggle).to_be_enabled(timeout=10_000)
        toggle.tap()
        expect(page.get_by_test_id("deadman")).to_have_text("3D mouse on — at rest")
        drives = page.get_by_test_id("mouse-drives")
        expect(drives.nth(2)).to_have_text("J3")
        page.get_by_test_id("mode-base").tap()
        expect(drives.nth(2)).to_have_text("Base Z")
        before = robot_state(runtime)["tcp_pose"]["position"]
        assert httpx.post(f"{mouse.url}/replay/start", timeout=5).status_code == 204
        expect(page.get_by_test_id("mouse-value").nth(2)).not_to_have_text("0 %")
        expect(page.get_by_test_id("deadman")).to_have_text("Moving with the 3D mouse")
        expect(page.get_by_test_id("deadman")).to_have_text("3D mouse on — at rest", timeout=5000)
        wait_for(lambda: robot_at_rest(runtime), 5, what="the robot stopped")
        after = robot_state(runtime)["tcp_pose"]["position"]
        moved = np.array(after) - np.array(before)
        assert moved[2] > 0.005, moved  # lifted, as the mouse was
        assert np.abs(moved[:2]).max() < 0.001, moved  # straight up
        mouse.stop()  # unplugged: the binding ends with a halt, said in full on the screen
        banner = page.get_by_test_id("deadman")
        expect(banner).to_contain_text("Halted", timeout=10_000)
        assert in_viewport(page, banner) or fits_the_screen(page)
        box = banner.bounding_box()
        assert box is not None and box["x"] + box["width"] <= PHONE["width"]
        page.screenshot(path=artifacts / "mouse-halted.png")
        page.get_by_test_id("control").tap()
        expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    finally:
        runtime.api("DELETE", "/devices/mouse")
        mouse.stop()


def test_the_tool_is_set_on_the_scene_panel_and_the_jog_readout_follows(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    flange = robot_state(runtime)["tcp_pose"]
    page.get_by_test_id("nav-scene").tap()
    editor = page.get_by_test_id("tool-z")
    expect(editor).to_have_value("0")
    for key, value in (("z", "150"), ("mass", "1.5")):
        field = page.get_by_test_id(f"tool-{key}")
        field.fill(value)
        field.dispatch_event("change")
    page.get_by_test_id("save-tool").tap()
    expect(page.get_by_test_id("tool-saved")).to_be_visible()
    stored = runtime.api("GET", "/variables/tools.robot").json()["value"]
    assert stored["tcp"]["position"] == [0.0, 0.0, 0.15]
    assert stored["payload"]["mass"] == 1.5
    # The TCP is now 150 mm out along the flange's z axis, on the Jog panel too.
    x, y, z, w = flange["orientation"]
    along_z = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
    expected = np.array(flange["position"]) + 0.15 * along_z
    page.get_by_test_id("nav-jog").tap()
    readout = page.get_by_test_id("tcp-readout")

    def shown() -> np.ndarray:
        words = readout.inner_text().split()
        return np.array([float(words[i]) for i in (2, 5, 8)]) / 1000  # "X mm <x> Y mm …"

    wait_for(lambda: np.abs(shown() - expected).max() < 0.0002, 5, what="the TCP readout")

    # Over the rated payload: refused with the reason, nothing changed.
    page.get_by_test_id("nav-scene").tap()
    page.get_by_test_id("tool-mass").fill("7")
    page.get_by_test_id("tool-mass").dispatch_event("change")
    page.get_by_test_id("save-tool").tap()
    expect(page.get_by_test_id("tool-message")).to_contain_text("rated payload of 5 kg")
    assert runtime.api("GET", "/variables/tools.robot").json()["value"]["payload"]["mass"] == 1.5

    for key in ("z", "mass"):  # back to the bare flange for the other tests
        page.get_by_test_id(f"tool-{key}").fill("0")
        page.get_by_test_id(f"tool-{key}").dispatch_event("change")
    page.get_by_test_id("save-tool").tap()
    expect(page.get_by_test_id("tool-saved")).to_be_visible()
    page.get_by_test_id("nav-jog").tap()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert [e for e in errors.errors if "422" not in e] == []


def jog_value(page: Page, axis: str) -> float:
    text = page.locator(f"[data-testid=jog-row][data-axis='{axis}'] [data-testid=jog-value]")
    return float(text.inner_text().split()[0].rstrip("°"))


def test_waypoints_say_where_they_go_filter_by_tag_and_show_the_move_under_way(
    runtime: Runtime, robot: str, phone: BrowserContext
) -> None:
    page = phone.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    deadman = page.get_by_test_id("deadman")
    expect(deadman).to_have_text("Take control to jog this robot")
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    if page.get_by_test_id("disable").count():
        page.get_by_test_id("disable").tap()
    expect(deadman).to_have_text("Enable the robot to jog it")
    page.get_by_test_id("enable").tap()
    expect(deadman).to_have_text("Ready: hold a button to jog")

    # A waypoint says where it puts the TCP: here, as the readout shows it.
    name = "pick_from_the_long_conveyor"
    page.get_by_test_id("teach-joint").tap()
    taught = page.locator("[data-testid=waypoint].selected")
    expect(taught.locator(".chip")).to_have_text("last used")
    runtime.api(
        "POST",
        f"/variables/{taught.get_attribute('data-name')}/rename",
        json={"to": name},
    )
    other = runtime.api("GET", f"/variables/{name}").json()
    runtime.api(
        "PUT",
        "/variables/place_on_tray",
        json={"type": "joint_waypoint", "value": other["value"], "tags": ["tray"]},
    )
    page.reload()
    item = page.locator(f"[data-testid=waypoint][data-name={name}]")
    expect(item.get_by_test_id("waypoint-coords")).to_contain_text("mm")
    readout = page.get_by_test_id("tcp-readout").inner_text().split()
    here = [float(readout[i]) for i in (2, 5, 8)]  # "X mm <x> Y mm <y> Z mm <z> ..."
    coords = item.get_by_test_id("waypoint-coords").inner_text().split()
    shown = [float(coords[i]) for i in (1, 4, 7)]  # "X <x> · Y <y> · Z <z> mm"
    assert np.allclose(shown, here, atol=0.15), (shown, here)
    box = item.locator(".name").bounding_box()
    assert box is not None and box["width"] > 150  # not wrapped letter by letter on a phone

    filter_box = page.get_by_test_id("waypoint-filter")
    filter_box.fill("tray")
    expect(page.get_by_test_id("waypoint")).to_have_count(1)
    expect(page.get_by_test_id("waypoint-count")).to_contain_text("1 of")
    filter_box.fill("")

    # Tool frame: the readings count along the tool's axes from where Tool was chosen.
    page.get_by_test_id("mode-tool").tap()
    expect(page.get_by_test_id("tool-note")).to_be_visible()
    assert abs(jog_value(page, "z")) < 0.05
    finger = Finger(page)
    finger.down(page.locator("[data-testid=jog-row][data-axis='z'] [data-testid=jog-plus]"))
    try:
        wait_for(lambda: jog_value(page, "z") > 5.0, 5, what="tool z counting up")
    finally:
        finger.up()
    wait_for(lambda: robot_at_rest(runtime), 5, what="stopped")
    assert abs(jog_value(page, "x")) < 1.0 and abs(jog_value(page, "y")) < 1.0

    # Moving to a waypoint shows how far is left, then that it arrived.
    finger.down(item.get_by_test_id("move-to"))
    try:
        expect(item.get_by_test_id("move-progress")).to_contain_text("mm to go")
        expect(deadman).to_contain_text(f"Moving to {name}")
        expect(deadman).to_contain_text("Arrived", timeout=20_000)
    finally:
        finger.up()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    for waypoint in (name, "place_on_tray"):
        runtime.api("DELETE", f"/variables/{waypoint}")
    assert errors.errors == []


def test_a_restarting_mouse_driver_keeps_the_3d_mouse_on_and_a_robot_restart_says_why_it_is_off(
    runtime: Runtime, robot: str, tablet: BrowserContext, tmp_path: Path
) -> None:
    """Issue 32: the mouse's own driver going away halts the robot but keeps the switch on,
    said on the card; back, the mouse drives again (from rest, by a new deflection). The
    robot's driver restarting is a lost link: the switch goes off, and the card says why.
    Last in the module: the runtime's own robot is killed (the launcher restarts it)."""
    mouse, recording = added_mouse(runtime, tmp_path, "restarting-mouse", rest=0.3)
    try:
        page = tablet.new_page()
        page.goto(f"{runtime.url}/#/jog")
        take_control_and_enable(page)
        page.get_by_test_id("mode-base").tap()
        toggle = page.get_by_test_id("mouse-toggle")
        note = page.get_by_test_id("mouse-note")
        deadman = page.get_by_test_id("deadman")
        expect(toggle).to_be_enabled(timeout=10_000)
        toggle.tap()
        expect(deadman).to_have_text("3D mouse on — at rest")

        mouse.stop()  # the mouse's driver restarts: first gone ...
        expect(deadman).to_contain_text("Halted", timeout=10_000)
        expect(toggle).to_have_text("3D mouse on — tap to turn off")
        expect(note).to_contain_text("Waiting for the 3D mouse")
        mouse = SpaceMouseProc(tmp_path, "restarting-mouse", recording)  # ... then back
        mouse.wait_ready()
        expect(deadman).to_have_text("3D mouse on — at rest", timeout=30_000)
        expect(toggle).to_have_text("3D mouse on — tap to turn off")
        expect(note).to_have_count(0)
        before = robot_state(runtime)["tcp_pose"]["position"]
        assert httpx.post(f"{mouse.url}/replay/start", timeout=5).status_code == 204
        expect(deadman).to_have_text("Moving with the 3D mouse")
        expect(deadman).to_have_text("3D mouse on — at rest", timeout=5000)
        wait_for(lambda: robot_at_rest(runtime), 5, what="the robot stopped")
        moved = np.array(robot_state(runtime)["tcp_pose"]["position"]) - np.array(before)
        assert moved[2] > 0.005, moved  # the binding made again drives the robot

        # The robot's driver restarts: a lost link ends the binding, and the card says so.
        driver = runtime.api("GET", "/devices/robot").json()["url"]
        os.kill(int(httpx.get(f"{driver}/health", timeout=5).json()["pid"]), signal.SIGKILL)
        expect(toggle).to_have_text("Use 3D mouse", timeout=10_000)
        expect(note).to_contain_text("3D mouse off:")
        wait_for(
            lambda: runtime.api("GET", "/devices/robot").json()["status"] == "connected",
            60,
            what="the robot back",
        )
        page.get_by_test_id("control").tap()
        expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    finally:
        runtime.api("DELETE", "/devices/mouse")
        mouse.stop()
