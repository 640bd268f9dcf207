"""The Program panel by touch: load a saved pick-and-place program, set a breakpoint on a
block, run it against the simulated robot and watch the highlighted block follow the run
and the robot move; step, resume, pause, stop. On a phone: drag a block out of the
toolbox, save the new program and run it."""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import BrowserContext, Locator, Page, expect

from openpendant.runtime.bench.harness import blocks as make
from openpendant.runtime.bench.harness.blocks import ids_of
from openpendant.runtime.bench.harness.processes import STILL, DriverProc, Runtime, wait_for
from tests.browser.conftest import (
    Finger,
    PageErrors,
    add_robot,
    fits_the_screen,
    robot_at_rest,
    robot_joints,
)
from tests.support.programs import (
    HOME,
    PICK_AND_PLACE_WAYPOINTS,
    pick_and_place,
    teach,
)


@pytest.fixture(scope="module")
def cell(runtime: Runtime) -> dict[str, Any]:
    """The robot, its waypoints and a saved pick-and-place program; returns that program."""
    add_robot(runtime)
    teach(runtime, PICK_AND_PLACE_WAYPOINTS)
    ws, main = pick_and_place()
    saved = runtime.api("PUT", "/programs/cycle", json={"workspace": ws})
    assert saved.status_code == 200, saved.text
    return main


def number(block_id: str) -> int:
    return int(block_id.rsplit("-", 1)[1])


def block_of(page: Page, block_id: str) -> Locator:
    return page.locator(f'g.blocklyDraggable[data-id="{block_id}"]')


def tap_block(page: Page, block_id: str) -> None:
    """A finger on the block's own top-left corner, clear of the blocks inside it."""
    block_of(page, block_id).locator("> .blocklyPath").tap(position={"x": 12, "y": 12})


def highlighted(page: Page) -> list[str]:
    ids: list[str] = page.locator("g.blocklyHighlighted").evaluate_all(
        "els => els.map(e => e.getAttribute('data-id'))"
    )
    return ids


def take_control_and_enable(page: Page, runtime: Runtime) -> None:
    page.goto(f"{runtime.url}/#/jog")
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    if page.get_by_test_id("enable").is_visible():
        page.get_by_test_id("enable").tap()
    expect(page.get_by_test_id("disable")).to_be_visible()


def test_run_a_saved_program_with_a_breakpoint_then_pause_and_stop(
    runtime: Runtime, cell: dict[str, Any], tablet: BrowserContext, artifacts: Path
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    take_control_and_enable(page, runtime)
    page.get_by_test_id("nav-program").tap()
    expect(page.get_by_test_id("program-select")).to_have_value("cycle")
    expect(block_of(page, cell["id"])).to_be_visible()
    page.get_by_test_id("tab-python").tap()
    expect(page.get_by_test_id("python")).to_contain_text("move_linear(waypoint('pick'))")
    page.screenshot(path=artifacts / "1-loaded.png")

    # A breakpoint on the "wait" block: tap the block, then the breakpoint button.
    ids = ids_of(cell)
    wait_block = next(i for i in ids if i.startswith("time_wait"))
    print_block = next(i for i in ids if i.startswith("text_print"))
    tap_block(page, wait_block)
    page.get_by_test_id("breakpoint").tap()
    expect(block_of(page, wait_block)).to_have_class(re.compile("opBreakpoint"))

    # Run: the highlight follows the program and the robot moves, up to the breakpoint.
    start = robot_joints(runtime)
    page.get_by_test_id("run").tap()
    seen: list[str] = []
    deadline = time.monotonic() + 60
    state = page.get_by_test_id("run-state")
    while state.text_content() != "paused":
        assert time.monotonic() < deadline, "never reached the breakpoint"
        for block_id in highlighted(page):
            if not seen or seen[-1] != block_id:
                seen.append(block_id)
        page.wait_for_timeout(30)
    # Each move of the first pass ("pick": the if-branch) takes long enough to be seen
    # highlighted, one after the other. Test block ids are numbered in program order.
    moves = sorted((i for i in ids if i.startswith("robot_move_")), key=number)
    assert [i for i in seen if i in moves] == moves[:3], seen
    assert set(seen) <= set(ids)
    assert np.abs(robot_joints(runtime) - start).max() > 0.3  # it went to the pick waypoints
    expect(page.get_by_test_id("run-block")).to_have_attribute("data-block", wait_block)
    assert highlighted(page) == [wait_block]
    page.screenshot(path=artifacts / "2-breakpoint.png")

    # Step: the wait runs, and the run pauses at the next block (the print).
    page.get_by_test_id("step").tap()
    expect(page.get_by_test_id("run-block")).to_have_attribute("data-block", print_block)
    expect(state).to_have_text("paused")
    # Clear the breakpoint while paused, then resume: the run goes on to its end.
    tap_block(page, wait_block)
    expect(page.get_by_test_id("breakpoint")).to_have_text("Clear breakpoint")
    page.get_by_test_id("breakpoint").tap()
    page.get_by_test_id("resume").tap()
    expect(state).to_have_text("finished", timeout=60_000)
    output = page.get_by_test_id("output")
    expect(output).to_contain_text("done pick")
    expect(output).to_contain_text("done place")
    expect(output).to_contain_text("cycle complete")
    assert highlighted(page) == []
    page.screenshot(path=artifacts / "3-finished.png")

    # Run again and pause: the robot comes to rest and stays there until resumed.
    page.get_by_test_id("run").tap()
    wait_for(lambda: not robot_at_rest(runtime), 20, what="the robot moving")
    page.get_by_test_id("pause").tap()
    expect(state).to_have_text("paused", timeout=20_000)
    wait_for(lambda: robot_at_rest(runtime), 20, what="the robot at rest while paused")
    paused_at = robot_joints(runtime)
    time.sleep(0.5)
    assert np.abs(robot_joints(runtime) - paused_at).max() < STILL

    # Resume, then stop during a move: the robot halts and the run ends.
    page.get_by_test_id("resume").tap()
    wait_for(lambda: not robot_at_rest(runtime), 20, what="the robot moving again")
    stop_requests: list[str] = []
    page.on("request", lambda r: stop_requests.append(r.url) if r.url.endswith("/stop") else None)
    page.get_by_test_id("stop").tap()
    expect(state).to_have_text("stopped")
    assert stop_requests == []  # the stop went over the program socket, not HTTP
    wait_for(lambda: robot_at_rest(runtime), 2, what="the robot halted")
    halted = robot_joints(runtime)
    time.sleep(0.5)
    assert np.abs(robot_joints(runtime) - halted).max() < STILL
    page.screenshot(path=artifacts / "4-stopped.png")

    page.get_by_test_id("nav-jog").tap()
    # The panel has picked its robot and knows this tab holds it before the tap.
    expect(page.get_by_test_id("control")).to_have_text("Release control")
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")
    assert errors.errors == []


def test_drag_a_block_from_the_toolbox_save_and_run_on_a_phone(
    runtime: Runtime, cell: dict[str, Any], phone: BrowserContext, artifacts: Path
) -> None:
    """The robot goes home: the program takes control itself (nobody else has it)."""
    wait_for(
        lambda: runtime.api("GET", "/devices/robot/lease").json()["holder"] is None,
        20,
        what="the tablet's control released",
    )
    page = phone.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    expect(page.get_by_test_id("program-select")).to_have_value("cycle")
    page.get_by_test_id("new").tap()
    expect(page.get_by_test_id("program-select")).to_have_value("")
    assert fits_the_screen(page)

    page.locator(".blocklyToolboxCategory", has_text="Robot").tap()
    source = page.locator(".blocklyFlyout g.blocklyDraggable", has_text="move home")
    expect(source).to_be_visible()
    workspace = page.get_by_test_id("workspace").bounding_box()
    assert workspace is not None
    Finger(page).drag(
        source, workspace["x"] + workspace["width"] - 120, workspace["y"] + workspace["height"] / 2
    )
    moved = page.locator("svg.blocklySvg .blocklyBlockCanvas > g", has_text="move home")
    expect(moved).to_have_count(1)
    expect(page.get_by_test_id("unsaved")).to_be_visible()
    page.wait_for_timeout(600)  # see below
    page.get_by_test_id("undo").tap()
    expect(moved).to_have_count(0)
    page.get_by_test_id("redo").tap()
    expect(moved).to_have_count(1)
    # A beat before the next tap, as a finger takes: Chromium's touch emulation drops a tap
    # that follows a drag's lift at once.
    page.wait_for_timeout(600)
    page.get_by_test_id("tab-python").tap()
    expect(page.get_by_test_id("python")).to_contain_text("move_home()")

    page.get_by_test_id("save").tap()
    page.get_by_test_id("name-input").fill("go_home")
    page.get_by_test_id("name-confirm").tap()
    expect(page.get_by_test_id("program-select")).to_have_value("go_home")
    expect(page.get_by_test_id("unsaved")).to_have_count(0)
    saved = runtime.api("GET", "/programs/go_home").json()
    assert saved["source"] == "blocks"
    assert "move_home()" in saved["python"]

    page.get_by_test_id("run").tap()
    expect(page.get_by_test_id("run-state")).to_have_text("finished", timeout=60_000)
    assert np.abs(robot_joints(runtime) - np.array(HOME)).max() < 1e-3
    assert fits_the_screen(page)
    page.screenshot(path=artifacts / "phone.png")
    assert errors.errors == []


def test_duplicate_rename_delete_export_and_import_a_program(
    runtime: Runtime, cell: dict[str, Any], tablet: BrowserContext, tmp_path: Path
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    select = page.get_by_test_id("program-select")
    expect(select).to_have_value("cycle")

    page.get_by_test_id("duplicate").tap()
    page.get_by_test_id("name-input").fill("cycle_b")
    page.get_by_test_id("name-confirm").tap()
    expect(select).to_have_value("cycle_b")
    expect(block_of(page, cell["id"])).to_be_visible()

    # A long press on a block opens its menu, with the breakpoint toggle.
    wait_block = next(i for i in ids_of(cell) if i.startswith("time_wait"))
    finger = Finger(page)
    finger.down(block_of(page, wait_block).locator("> .blocklyPath"), offset=(12, 12))
    page.wait_for_timeout(1200)
    finger.up()
    page.get_by_role("menuitem", name="Add breakpoint").tap()
    expect(block_of(page, wait_block)).to_have_class(re.compile("opBreakpoint"))

    page.get_by_test_id("rename").tap()
    page.get_by_test_id("name-input").fill("cycle")
    page.get_by_test_id("name-confirm").tap()
    expect(page.get_by_role("alert")).to_contain_text("exists")  # the server's word, in place
    page.get_by_test_id("name-input").fill("cycle_c")
    page.get_by_test_id("name-confirm").tap()
    expect(select).to_have_value("cycle_c")
    names = [p["name"] for p in runtime.api("GET", "/programs").json()]
    assert "cycle_c" in names and "cycle_b" not in names

    page.get_by_test_id("delete").tap()
    page.get_by_test_id("delete-confirm").tap()
    expect(select).not_to_have_value("cycle_c")
    assert runtime.api("GET", "/programs/cycle_c").status_code == 404
    assert runtime.api("GET", "/programs/cycle").status_code == 200

    # Out as a file (for version control) and back in under another name.
    select.select_option("cycle")
    expect(select).to_have_value("cycle")
    with page.expect_download() as downloading:
        page.get_by_test_id("export").tap()
    download = downloading.value
    assert download.suggested_filename == "cycle.openpendant.json"
    saved = tmp_path / download.suggested_filename
    download.save_as(saved)
    with page.expect_file_chooser() as choosing:
        page.get_by_test_id("import").tap()
    choosing.value.set_files(saved)
    expect(page.get_by_test_id("name-input")).to_have_value("cycle")  # the file's name
    page.once("dialog", lambda question: question.dismiss())  # "Replace cycle?": no
    page.get_by_test_id("name-confirm").tap()
    expect(page.get_by_test_id("name-input")).to_be_visible()
    page.get_by_test_id("name-input").fill("cycle_d")
    page.get_by_test_id("name-confirm").tap()
    expect(select).to_have_value("cycle_d")
    expect(block_of(page, cell["id"])).to_be_visible()
    original, imported = (runtime.api("GET", f"/programs/{n}").json() for n in ("cycle", "cycle_d"))
    assert imported["python"] == original["python"]
    assert imported["workspace"] == original["workspace"]
    # The one refused rename, which the browser logs as a failed request.
    assert len(errors.errors) == 1 and "409" in errors.errors[0], errors.errors


def test_a_waypoint_taught_elsewhere_is_offered_at_once(
    runtime: Runtime, cell: dict[str, Any], tablet: BrowserContext
) -> None:
    """The dropdowns follow the variable storage: taught or deleted on another pendant (here
    the API) while this panel is open, a waypoint appears in or leaves the list."""
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    expect(page.get_by_test_id("program-select")).to_have_value("cycle")
    chooser = next(i for i in ids_of(cell) if i.startswith("waypoint_get"))
    field = block_of(page, chooser).locator(".blocklyDropdownField").first
    option = page.locator(".blocklyDropDownDiv .blocklyMenuItem", has_text="spot_taught_now")
    expect(field).to_be_visible()

    def offered() -> bool:
        field.tap()
        listed = option.count() > 0
        page.keyboard.press("Escape")
        return listed

    teach(runtime, {"spot_taught_now": HOME})
    wait_for(offered, 10, what="the new waypoint offered")
    runtime.api("DELETE", "/variables/spot_taught_now").raise_for_status()
    wait_for(lambda: not offered(), 10, what="the deleted waypoint gone from the list")
    assert errors.errors == []


def statements(first: dict[str, Any]) -> list[str]:
    """A stack's statement blocks in the order they run (values left out)."""
    found: list[str] = []
    block: dict[str, Any] | None = first
    while block is not None:
        found.append(block["id"])
        for name, child in block.get("inputs", {}).items():
            if name.startswith(("DO", "ELSE")):
                found += statements(child["block"])
        block = block.get("next", {}).get("block")
    return found


def test_the_program_reads_as_an_outline_beside_the_blocks_and_a_3d_view(
    runtime: Runtime, cell: dict[str, Any], phone: BrowserContext
) -> None:
    page = phone.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    expect(page.get_by_test_id("program-select")).to_have_value("cycle")
    expect(block_of(page, cell["id"])).to_be_visible()

    # The outline: one line per statement, in the order they run, nested as they are.
    page.get_by_test_id("tab-outline").tap()
    items = page.get_by_test_id("outline-item")
    expect(items).to_have_count(len(statements(cell)))
    shown = items.evaluate_all("els => els.map(e => e.dataset.block)")
    assert shown == statements(cell)
    first_move = items.filter(has_text="move joint").first
    expect(first_move).to_contain_text("above_pick")
    indent = first_move.evaluate("e => parseFloat(e.style.paddingLeft)")
    assert indent > items.first.evaluate("e => parseFloat(e.style.paddingLeft)")
    # A tap goes to the block: it is selected, so a breakpoint can be set on it.
    revealed = first_move.get_attribute("data-block")
    assert revealed is not None
    first_move.tap()
    expect(page.get_by_test_id("breakpoint")).to_be_enabled()
    assert fits_the_screen(page)

    # A dropdown's rows are big enough for a finger.
    page.get_by_test_id("tab-output").tap()
    dropdown = block_of(page, revealed).locator(".blocklyDropdownText").first
    dropdown.tap()
    row = page.locator(".blocklyMenuItem").first
    expect(row).to_be_visible()
    box = row.bounding_box()
    assert box is not None and box["height"] >= 44, box
    page.keyboard.press("Escape")

    # The robot in focus, live, in the 3D tab.
    page.get_by_test_id("tab-view").tap()
    view = page.get_by_test_id("program-view").get_by_test_id("robot-view")
    expect(view).to_have_attribute("data-status", "ready", timeout=60_000)
    expect(view).to_have_attribute("data-robot", "robot")

    # The Python reads line for line: no line wraps under the one before it.
    page.get_by_test_id("tab-python").tap()
    code = page.get_by_test_id("python").locator("pre")
    expect(code).to_contain_text("move_joint(")
    lines, height, line_height = code.evaluate(
        "e => [e.textContent.split('\\n').length, e.scrollHeight,"
        " parseFloat(getComputedStyle(e).lineHeight)]"
    )
    assert height <= lines * line_height + 2, (lines, height, line_height)
    assert errors.errors == []


def test_every_block_fits_the_toolbox_on_a_phone(
    runtime: Runtime, cell: dict[str, Any], phone: BrowserContext
) -> None:
    # In English, beside a program with variables; test_pendant_settings checks German.
    page = phone.new_page()
    page.goto(f"{runtime.url}/#/program")
    expect(block_of(page, cell["id"])).to_be_visible()
    screen = page.viewport_size
    assert screen is not None
    categories = page.locator(".blocklyToolboxCategory")
    assert categories.count() >= 8
    for index in range(categories.count()):
        category = categories.nth(index)
        category.tap()
        blocks = page.locator(".blocklyFlyout .blocklyBlockCanvas > g.blocklyDraggable")
        expect(blocks.first).to_be_visible()
        for block in blocks.all():
            box = block.bounding_box()
            assert box is not None
            wide = f"{category.inner_text()}: {block.text_content()}"
            assert box["x"] + box["width"] <= screen["width"], wide


def test_the_io_blocks_offer_an_io_blocks_signals_by_name(
    runtime: Runtime, tablet: BrowserContext
) -> None:
    device = DriverProc(runtime.home, "modbus-io", "cell-io", "--simulate")
    try:
        url = device.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "cell_io"})
        assert added.status_code in (200, 201), added.text
        top = make.block(
            "io_set_output",
            {"NAME": "cell_io.lamp_green"},
            VALUE=make.block("logic_boolean", {"BOOL": "TRUE"}),
        )
        saved = runtime.api("PUT", "/programs/lamp", json={"workspace": make.workspace(top)})
        assert saved.status_code == 200, saved.text
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/program")
        page.get_by_test_id("program-select").select_option("lamp")
        # The block's own dropdown (its value input holds another: the boolean's).
        field = page.locator(f'[id^="{top["id"]}_field"]').filter(has_text="cell_io")
        expect(field).to_contain_text("cell_io.lamp_green")
        field.tap()
        menu = page.locator(".blocklyMenuItem")
        expect(menu.filter(has_text="cell_io.out7")).to_be_visible()
        offered = menu.all_inner_texts()
        assert "cell_io.feeder_run" in offered and "cell_io.part_present" not in offered
        menu.filter(has_text="cell_io.feeder_run").tap()
        expect(field).to_contain_text("cell_io.feeder_run")
        assert errors.errors == []
    finally:
        runtime.api("DELETE", "/programs/lamp")
        runtime.api("DELETE", "/devices/cell_io")
        device.stop()


def test_problems_refusals_and_run_errors_read_in_the_language_chosen(
    runtime: Runtime, cell: dict[str, Any], tablet: BrowserContext
) -> None:
    """Issue 32: in German, what the runtime said stayed English. Now its words are the UI's:
    a pre-run problem, a run's refused call and a refusal of control, each in German."""
    unfinished = make.block("controls_repeat_ext")
    saved = runtime.api(
        "PUT", "/programs/unfinished", json={"workspace": make.workspace(unfinished)}
    )
    assert saved.status_code == 200, saved.text
    assert saved.json()["problems"][0]["words"]["code"] == "program.input_empty"
    python = {"python": "store('frames.x', 1)\n"}
    assert runtime.api("PUT", "/programs/frames_writer", json=python).status_code == 200
    held: str | None = None
    try:
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/system")
        page.get_by_test_id("language-de").tap()
        page.get_by_test_id("nav-program").tap()
        page.get_by_test_id("program-select").select_option("unfinished")
        expect(page.get_by_test_id("problem-item")).to_have_text(
            "⚠ Block „repeat ext“: die Anzahl der Wiederholungen fehlt"
        )
        expect(page.get_by_test_id("run")).to_be_disabled()

        # A call the runtime refuses while the program runs: the error in the output.
        page.get_by_test_id("program-select").select_option("frames_writer")
        page.get_by_test_id("run").tap()
        expect(page.get_by_test_id("run-error")).to_have_text(
            "frames.x ist reserviert: Namen unter frames. darf ein Programm lesen, aber nicht"
            " ändern (Zeile 1)",
            timeout=15_000,
        )

        # Control of the robot, refused: someone else holds it.
        taken = runtime.api("POST", "/devices/robot/lease", json={"holder": "Pendant am Band"})
        assert taken.status_code == 200, taken.text
        held = taken.json()["token"]
        page.get_by_test_id("nav-jog").tap()
        expect(page.get_by_test_id("lease")).to_contain_text("Pendant am Band")
        page.get_by_test_id("control").tap()
        expect(page.get_by_test_id("jog-message")).to_have_text(
            "robot wird von „Pendant am Band“ gesteuert"
        )
        assert all("409" in e for e in errors.errors), errors.errors  # the refusal itself
    finally:
        if held is not None:
            runtime.api("DELETE", "/devices/robot/lease", headers={"X-Lease-Token": held})
        runtime.api("DELETE", "/programs/unfinished")
        runtime.api("DELETE", "/programs/frames_writer")
