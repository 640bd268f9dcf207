"""The Jog panel by touch: take control, enable, hold a jog button (the robot moves while the
finger is down and stops when it lifts), teach a waypoint, move away, hold "move to" until it
arrives, a live 3D view of the robot and the simulated cell's parts, freedrive held while a
hand moves the arm, a gripper opened and closed beside the buttons, and what stops the
robot said with what to do (a UR's own words for its power-on and unlock too)."""

from __future__ import annotations

import re
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from playwright.sync_api import BrowserContext, Locator, Route, expect

from openpendant.device_drivers.ur_rtde.emulator import control as emulator_control
from openpendant.runtime.bench.harness.processes import (
    STILL,
    DriverProc,
    Runtime,
    SimRobotProc,
    wait_for,
)
from tests.browser.conftest import (
    Finger,
    PageErrors,
    add_robot,
    fits_the_screen,
    robot_at_rest,
    robot_joints,
)
from tests.browser.test_shop_floor import take_control_and_enable
from tests.support.held_handshake import CLOSE, HeldHandshake
from tests.support.png import decode

UR_HOST = "127.0.0.8"  # the UR emulator's own loopback address (its ports are fixed)


@pytest.fixture(scope="module")
def robot(runtime: Runtime) -> str:
    return add_robot(runtime)


def robot_pixels(png: bytes) -> int:
    """Neutral grey pixels: the robot's links. The background and grid are blue-grey."""
    image = decode(png)[:, :, :3].astype(int)
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return int(((abs(r - g) < 8) & (abs(g - b) < 8) & (r > 40)).sum())


def test_jog_teach_and_move_to_by_touch(
    runtime: Runtime, robot: str, tablet: BrowserContext, artifacts: Path
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    page.get_by_test_id("enable").tap()
    expect(page.get_by_test_id("disable")).to_be_visible()

    # The 3D view renders the robot.
    view = page.get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    page.wait_for_timeout(300)
    page.screenshot(path=artifacts / "1-jog-panel.png")
    assert robot_pixels(view.screenshot(path=artifacts / "2-robot-view.png")) > 500
    # The closest distance to anything else in the scene shows beside the view.
    expect(page.get_by_test_id("clearance")).to_contain_text("Nothing near")

    finger = Finger(page)
    j1_plus = page.locator("[data-testid=jog-row][data-axis='0'] [data-testid=jog-plus]")

    # Hold J1 +: it moves while held...
    before = robot_joints(runtime)
    finger.down(j1_plus)
    try:
        wait_for(lambda: robot_joints(runtime)[0] > before[0] + 0.05, 5, what="J1 moving")
        expect(page.get_by_test_id("deadman")).to_contain_text("Moving")
    finally:
        finger.up()
    # ... and stops when the finger lifts.
    wait_for(lambda: robot_at_rest(runtime), 3, what="stopped on release")
    stopped = robot_joints(runtime)
    time.sleep(0.3)
    assert np.abs(robot_joints(runtime) - stopped).max() < STILL
    moved = stopped - before
    assert moved[0] > 0.05
    assert np.abs(moved[1:]).max() < 1e-9

    # Teach the position as a waypoint with one tap, then name and tag it.
    page.get_by_test_id("teach-joint").tap()
    expect(page.locator("[data-testid=waypoint][data-name=wp_001]")).to_be_visible()
    page.locator("[data-testid=waypoint][data-name=wp_001] [data-testid=rename]").tap()
    page.get_by_test_id("name-input").fill("pick_1")
    page.get_by_test_id("tags-input").fill("cell-2, pick")
    page.get_by_test_id("name-confirm").tap()
    waypoint = page.locator("[data-testid=waypoint][data-name=pick_1]")
    expect(waypoint).to_be_visible()
    stored = runtime.api("GET", "/variables/pick_1").json()
    assert stored["tags"] == ["cell-2", "pick"]
    taught = np.array(stored["value"]["joints"])
    assert np.allclose(taught, stopped, atol=1e-9)

    # Move away (J2 −) ...
    j2_minus = page.locator("[data-testid=jog-row][data-axis='1'] [data-testid=jog-minus]")
    finger.down(j2_minus)
    try:
        wait_for(lambda: robot_joints(runtime)[1] < stopped[1] - 0.05, 5, what="J2 moving")
    finally:
        finger.up()
    wait_for(lambda: robot_at_rest(runtime), 3)
    assert np.abs(robot_joints(runtime) - taught).max() > 0.05

    # ... then hold "move to" until it arrives.
    finger.down(waypoint.get_by_test_id("move-to"))
    try:
        expect(page.get_by_test_id("deadman")).to_contain_text("Arrived", timeout=20_000)
    finally:
        finger.up()
    assert np.allclose(robot_joints(runtime), taught, atol=1e-6)
    page.screenshot(path=artifacts / "3-arrived.png")

    # Done: hand control back, so another pendant may take it.
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert runtime.api("GET", "/devices/robot/lease").json()["holder"] is None
    assert errors.errors == []


def test_sliding_off_a_held_button_stops_the_robot(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    finger = Finger(page)
    button = page.locator("[data-testid=jog-row][data-axis='5'] [data-testid=jog-plus]")
    before = robot_joints(runtime)
    finger.down(button)
    try:
        wait_for(lambda: robot_joints(runtime)[5] > before[5] + 0.03, 5, what="J6 moving")
        finger.move(200, 150)  # the finger slides off the button, still on the glass
        wait_for(lambda: robot_at_rest(runtime), 3, what="stopped when the finger left the button")
    finally:
        finger.up()
    expect(page.get_by_test_id("deadman")).to_contain_text("Stopped")
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def test_freedrive_is_held_by_touch_and_a_hand_moves_the_arm(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """Hold Freedrive: the arm follows a hand on its wrist. Lift the finger: it holds where
    the hand left it, though the hand still pushes."""
    hand = f"{runtime.api('GET', '/devices/robot').json()['url']}/sim/hand"
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    button = page.get_by_test_id("freedrive")
    expect(button).to_be_visible()
    httpx.put(hand, json={"velocity": [0, 0, 0, 0, 0.3, 0]}, timeout=5).raise_for_status()
    try:
        before = robot_joints(runtime)
        finger = Finger(page)
        finger.down(button)
        try:
            wait_for(lambda: robot_joints(runtime)[4] > before[4] + 0.05, 5, what="J5 by hand")
            expect(page.get_by_test_id("deadman")).to_contain_text("by hand")
        finally:
            finger.up()
        wait_for(lambda: robot_at_rest(runtime), 3, what="held when the finger lifted")
        held = robot_joints(runtime)
        time.sleep(0.3)  # the hand still pushes
        assert np.abs(robot_joints(runtime) - held).max() < STILL
        assert np.abs(np.delete(held - before, 4)).max() < 1e-9
        expect(page.get_by_test_id("deadman")).to_contain_text("Stopped")
    finally:
        httpx.put(hand, json={"velocity": [0.0] * 6}, timeout=5)
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert errors.errors == []


def part_pixels(png: bytes) -> int:
    """Wooden-brown pixels: the cell's parts. The robot is grey, the background blue-grey,
    waypoint markers orange (far less blue for their red)."""
    image = decode(png)[:, :, :3].astype(int)
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return int(((r - b > 50) & (r > g) & (g > b) & (b * 100 > r * 35)).sum())


def test_the_simulated_cells_parts_show_in_the_3d_view_where_they_lie(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """Parts laid on the simulated robot's table are drawn where they lie, and follow when
    they move."""
    table = f"{runtime.api('GET', '/devices/robot').json()['url']}/sim/cell"

    def lay(*parts: tuple[str, list[float]]) -> None:
        layout = [{"id": i, "size": [0.1] * 3, "pose": {"position": at}} for i, at in parts]
        httpx.put(table, json={"parts": layout}, timeout=5).raise_for_status()

    lay()  # an empty table first: what else the view shows in a part's colour (little)
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    view = page.get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    expect(view).to_have_attribute("data-parts", "", timeout=10_000)
    # The most of three frames (the software renderer draws at most every 200 ms).
    empty = max(part_pixels(view.screenshot()) for _ in range(3))
    lay(("crate", [0.4, -0.25, 0.05]))
    expect(view).to_have_attribute("data-parts", "crate@0.400,-0.250,0.050", timeout=10_000)
    wait_for(lambda: part_pixels(view.screenshot()) > empty + 200, 10, what="the crate drawn")
    lay(("crate", [0.4, 0.25, 0.05]), ("bin", [0.3, 0.0, 0.05]))
    expect(view).to_have_attribute(
        "data-parts", "crate@0.400,0.250,0.050 bin@0.300,0.000,0.050", timeout=10_000
    )
    lay()
    expect(view).to_have_attribute("data-parts", "", timeout=10_000)
    wait_for(lambda: part_pixels(view.screenshot()) <= empty + 20, 10, what="no part drawn")
    assert errors.errors == []


def test_what_stops_the_robot_is_said_with_what_to_do(
    runtime: Runtime, robot: str, tablet: BrowserContext, tmp_path: Path
) -> None:
    """The E-stop, a fault (the driver's own words shown) and a lost link, each in a card
    under the robot's name that says what to do; gone when the cause is."""
    sim = runtime.api("GET", "/devices/robot").json()["url"]
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    fault = page.get_by_test_id("robot-fault")
    expect(fault).to_have_count(0)
    try:
        httpx.post(f"{sim}/sim/estop", json={"engaged": True}, timeout=5).raise_for_status()
        expect(fault).to_have_attribute("data-kind", "estop", timeout=5_000)
        expect(fault).to_contain_text("release the E-stop button")
        chip = page.locator("[data-testid=status-robot][data-name=robot]")
        expect(chip).to_contain_text("E-STOP")
        httpx.post(f"{sim}/sim/estop", json={"engaged": False}, timeout=5).raise_for_status()
        expect(fault).to_have_count(0, timeout=5_000)

        fault_request = {"message": "joint 3 overcurrent"}
        httpx.post(f"{sim}/sim/fault", json=fault_request, timeout=5).raise_for_status()
        expect(fault).to_have_attribute("data-kind", "error", timeout=5_000)
        expect(page.get_by_test_id("robot-fault-detail")).to_have_text("joint 3 overcurrent")
        page.get_by_role("button", name="Reset error").tap()
        expect(fault).to_have_count(0, timeout=5_000)
    finally:
        httpx.post(f"{sim}/sim/estop", json={"engaged": False}, timeout=5)
        runtime.api("POST", "/jog/robots/robot/reset_errors", headers={})
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")

    # A robot whose link is lost: said so, with what to do, until it is back.
    spare = SimRobotProc(tmp_path, name="fault-test-robot")
    try:
        spare.wait_ready()
        pairing = {"url": spare.url, "local_name": "spare", "pairing": spare.secret}
        added = runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        page.locator("[data-testid=status-robot][data-name=spare]").tap()
        expect(page.get_by_test_id("jog-robot")).to_have_text("spare", timeout=10_000)
        expect(fault).to_have_count(0, timeout=10_000)
        spare.stop()
        expect(fault).to_have_attribute("data-kind", "link", timeout=10_000)
        expect(fault).to_contain_text("No link to spare")
        expect(fault).to_contain_text("nothing moves until you enable it again")
        # Loads of a robot whose link is not (yet, or any more) up answer 503 and are tried
        # again: the browser logs each; nothing else may have gone wrong.
        failed = [e for e in errors.errors if not e.startswith("Failed to load resource")]
        assert failed == []  # before the robot in focus is removed under the page
    finally:
        spare.stop()
        runtime.api("DELETE", "/devices/spare")


def test_a_move_pushed_off_its_path_is_a_protective_stop_said_in_the_card(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """The path monitor (issue 31): a hand pushes the arm off a joint move's path; the Jog
    panel's card says it is a protective stop, with the monitor's words and what to do;
    Reset error clears it."""
    sim = runtime.api("GET", "/devices/robot").json()["url"]
    wait_for(
        lambda: runtime.api("GET", "/devices/robot/lease").json()["holder"] is None,
        20,
        what="the earlier pendants' control released",
    )
    lease = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]
    mine = {"X-Lease-Token": lease}
    try:
        assert runtime.api("POST", "/jog/robots/robot/enable", headers=mine).status_code == 200
        q = np.array(runtime.api("GET", "/devices/robot/state").json()["joint_position"])
        goal = q.copy()
        goal[0] += -0.8 if q[0] > 0 else 0.8  # the base turns, away from its limit
        request = {"kind": "joint", "target": {"joints": goal.tolist()}, "speed": 0.3}
        started = runtime.api("POST", "/motion/robots/robot/moves", json=request, headers=mine)
        assert started.status_code == 202, started.text
        move = started.json()["id"]
        wait_for(
            lambda: runtime.api("GET", f"/motion/moves/{move}").json()["progress"] > 0.05,
            10,
            what="the move under way",
        )
        httpx.put(f"{sim}/sim/hand", json={"velocity": [0, 0.3, 0, 0, 0, 0]}, timeout=5)
        ended = wait_for(
            lambda: (lambda s: s if s["state"] not in ("planning", "running") else None)(
                runtime.api("GET", f"/motion/moves/{move}").json()
            ),
            10,
            what="the move stopped",
        )
        assert ended["code"] == "path_deviation", ended
    finally:
        httpx.put(f"{sim}/sim/hand", json={"velocity": [0.0] * 6}, timeout=5)
        runtime.api("DELETE", "/devices/robot/lease", headers=mine)
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    fault = page.get_by_test_id("robot-fault")
    expect(fault).to_have_attribute("data-kind", "protective_stop", timeout=10_000)
    expect(fault).to_contain_text("pushed off its path")
    detail = page.get_by_test_id("robot-fault-detail")  # the monitor's words, either check
    expect(detail).to_have_text(
        re.compile(r"protective stop: the (TCP|joints) left (its|their) planned path by")
    )
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    page.get_by_role("button", name="Reset error").tap()
    expect(fault).to_have_count(0, timeout=5_000)
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert errors.errors == []


def test_without_control_the_pad_does_nothing(
    runtime: Runtime, robot: str, phone: BrowserContext
) -> None:
    """Another pendant (a phone) sees who has control; its buttons are disabled."""
    wait_for(
        lambda: runtime.api("GET", "/devices/robot/lease").json()["holder"] is None,
        20,
        what="the earlier pendants' control released",
    )
    taken = runtime.api("POST", "/devices/robot/lease", json={"holder": "Pendant on the cell"})
    assert taken.status_code == 200
    page = phone.new_page()
    page.goto(f"{runtime.url}/#/jog")
    expect(page.get_by_test_id("lease")).to_contain_text("Controlled by Pendant on the cell")
    plus = page.locator("[data-testid=jog-row][data-axis='0'] [data-testid=jog-plus] button")
    expect(plus).to_be_disabled()
    assert fits_the_screen(page)
    # A touch on a disabled button says why where the finger is (issue 32).
    touched = page.locator("[data-testid=jog-row][data-axis='0'] [data-testid=jog-plus]")
    touched.tap()
    said = page.get_by_test_id("refusal-reason")
    expect(said).to_contain_text("Take control to jog this robot")
    assert beside(said, touched)


def test_the_gripper_is_activated_closed_on_a_part_and_opened_from_the_jog_panel(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """A simulated Robotiq 2F-85 (on pymodbus's server) beside the jog buttons."""
    device = DriverProc(runtime.home, "modbus-gripper", "sim-gripper", "--simulate")
    try:
        url = device.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "gripper"})
        assert added.status_code in (200, 201), added.text
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/jog")
        card = page.locator("[data-testid=gripper][data-name=gripper]")
        expect(card).to_be_visible(timeout=15_000)
        page.get_by_test_id("gripper-control-gripper").tap()
        page.get_by_test_id("gripper-activate-gripper").tap()
        close = page.get_by_test_id("gripper-close-gripper")
        expect(close).to_be_enabled(timeout=10_000)
        httpx.put(f"{url}/sim/object", json={"width": 0.03}, timeout=5)
        close.tap()
        expect(card).to_have_attribute("data-holds", "true", timeout=10_000)
        expect(page.get_by_test_id("gripper-holds")).to_be_visible()
        expect(page.get_by_test_id("gripper-reading")).to_contain_text("30")  # mm open
        page.get_by_test_id("gripper-open-gripper").tap()
        expect(card).to_have_attribute("data-holds", "false", timeout=10_000)
        wait_for(
            lambda: httpx.get(f"{url}/sim/fingers", timeout=5).json()["width"] > 0.0849,
            10,
            what="the fingers fully open",
        )
        page.get_by_test_id("gripper-release-gripper").tap()
        expect(page.get_by_test_id("gripper-control-gripper")).to_be_visible()
        assert errors.errors == []
    finally:
        runtime.api("DELETE", "/devices/gripper")
        device.stop()


def test_a_ur_says_what_enable_and_reset_do_on_it(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """A UR (its driver through ur-rtde to the controller emulator): Enable says it powers
    the arm on; after a protective stop the card and the button say Reset error unlocks it;
    the controller's reduced mode is shown while it lasts."""
    emulator = emulator_control.start(UR_HOST)
    # The RTDE watchdog at 2 Hz, not the product's 10: as the browser tests' deadman and link
    # timeouts (conftest.py), widened here for a software-rendered Chromium sharing two cores
    # with the runtime (once the driver's kick came over 100 ms late and the controller
    # stopped its program, as it should); test_ur_driver.py proves the 10 Hz default.
    driver = DriverProc(
        runtime.home, "ur-rtde", "ur", "--address", UR_HOST, "--model", "ur5e", "--watchdog-hz", "2"
    )
    try:
        url = driver.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "ur"})
        assert added.status_code in (200, 201), added.text
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/jog")
        page.locator("[data-testid=status-robot][data-name=ur]").tap()
        expect(page.get_by_test_id("jog-robot")).to_have_text("ur", timeout=10_000)
        page.get_by_test_id("control").tap()
        expect(page.get_by_test_id("lease")).to_contain_text("You have control")
        enable = page.get_by_test_id("enable")
        expect(enable).to_have_text("Power on & enable", timeout=15_000)
        enable.tap()
        expect(page.get_by_test_id("disable")).to_be_visible(timeout=15_000)

        emulator_control.world(UR_HOST, "reduced on")
        expect(page.get_by_test_id("robot-reduced")).to_be_visible(timeout=5_000)
        emulator_control.world(UR_HOST, "reduced off")
        expect(page.get_by_test_id("robot-reduced")).to_have_count(0, timeout=5_000)

        emulator_control.world(UR_HOST, "protective stop")
        fault = page.get_by_test_id("robot-fault")
        expect(fault).to_have_attribute("data-kind", "protective_stop", timeout=5_000)
        expect(fault).to_contain_text("tap Unlock & reset")
        chip = page.locator("[data-testid=status-robot][data-name=ur]")
        expect(chip).to_contain_text("PROTECTIVE STOP")
        unlock = page.get_by_test_id("reset-error")
        expect(unlock).to_have_text("Unlock & reset")
        unlock.tap()
        expect(fault).to_have_count(0, timeout=10_000)
        assert emulator_control.emulated(UR_HOST)["safety_mode"] == 1  # normal: unlocked
        enable.tap()  # nothing resumed by itself: enabled again by hand
        expect(page.get_by_test_id("disable")).to_be_visible(timeout=15_000)
        page.get_by_test_id("control").tap()
        expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
        failed = [e for e in errors.errors if not e.startswith("Failed to load resource")]
        assert failed == []
    finally:
        runtime.api("DELETE", "/devices/ur")
        driver.stop()
        emulator_control.stop(emulator)


def beside(said: Locator, control: Locator) -> bool:
    """The bubble is over the control it speaks for (within a finger's reach of it)."""
    bubble, box = said.bounding_box(), control.bounding_box()
    assert bubble is not None and box is not None
    overlaps = bubble["x"] < box["x"] + box["width"] and box["x"] < bubble["x"] + bubble["width"]
    return overlaps and abs(bubble["y"] + bubble["height"] - box["y"]) < box["height"] + 60


def test_a_refused_move_to_says_why_at_the_button_held(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """Issue 32: a held Move to the robot refused only cleared its progress, the reason in a
    status line elsewhere. The button held says it."""
    wait_for(
        lambda: runtime.api("GET", "/devices/robot/lease").json()["holder"] is None,
        20,
        what="the earlier pendants' control released",
    )
    beyond = [0.0, -1.57, 1.57, -1.57, -1.57, 9.0]  # the wrist turned past its limit
    value = {"type": "joint_waypoint", "value": {"joints": beyond, "robot": robot}}
    assert runtime.api("PUT", "/variables/beyond_the_wrist", json=value).status_code == 200
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    waypoint = page.locator("[data-testid=waypoint][data-name=beyond_the_wrist]")
    move_to = waypoint.get_by_test_id("move-to")
    before = robot_joints(runtime)
    finger = Finger(page)
    finger.down(move_to)
    try:
        said = page.get_by_test_id("refusal-reason")
        expect(said).to_contain_text("Refused")
        assert beside(said, move_to)
    finally:
        finger.up()
    assert np.abs(robot_joints(runtime) - before).max() < 1e-3
    page.get_by_test_id("control").tap()
    assert errors.errors == []


def test_leaving_the_panel_while_its_jog_socket_connects_closes_it_cleanly(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    """A CI run: a tablet whose session ended while its jog socket was still connecting
    closed it half-way, the browser reported an error and the jog service logged a dropped
    handshake. A socket still connecting is closed once it opens, and nothing it carries
    reaches the page. Here the jog socket's handshake is held (the page is pointed at a
    server that answers only when told), and the page leaves the panel meanwhile."""
    held = HeldHandshake()
    try:

        def to_held(route: Route) -> None:
            settings = {**route.fetch().json(), "socket_port": held.port}
            route.fulfill(json=settings)

        page = tablet.new_page()
        errors = PageErrors(page)
        page.route("**/api/jog/settings", to_held)
        with page.expect_websocket(lambda ws: f":{held.port}/" in ws.url, timeout=20_000):
            page.goto(f"{runtime.url}/#/jog")
        held.wait_asked(timeout=10)
        assert b"GET /jog/ws?ticket=" in held.request
        page.get_by_test_id("nav-devices").tap()
        expect(page.get_by_test_id("jog-row")).to_have_count(0)  # the jog panel is gone
        assert held.answer(), "the page dropped the socket while it connected"
        assert held.first_frame_opcode() == CLOSE  # closed once open, by the page
        page.get_by_test_id("nav-jog").tap()
        expect(page.get_by_test_id("jog-row")).to_have_count(6)
        assert errors.errors == []
        # The panel asks for its settings again as it retries its socket: a fetch of the
        # route still under way when the context closes would fail ("response disposed").
        page.unroute_all(behavior="ignoreErrors")
    finally:
        held.close()
