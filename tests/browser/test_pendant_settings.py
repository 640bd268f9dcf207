"""This pendant's own settings on the System panel: a light theme for bright rooms (kept
across reloads, on every panel and in the block editor) and a name people chose, which
others see while it has control."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import BrowserContext, Page, expect

from tests.browser.conftest import PageErrors, add_robot, fits_the_screen
from tests.support.processes import Runtime, SimRobotProc, wait_for

DARK_BG = "rgb(16, 22, 29)"
LIGHT_BG = "rgb(244, 246, 248)"


@pytest.fixture(scope="module")
def robot(runtime: Runtime) -> str:
    return add_robot(runtime)


def background(page: Page) -> str:
    colour: str = page.evaluate("getComputedStyle(document.body).backgroundColor")
    return colour


def test_the_light_theme_is_chosen_on_the_system_panel_and_kept(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/system")
    assert background(page) == DARK_BG
    page.get_by_test_id("theme-light").tap()
    expect(page.get_by_test_id("theme-light")).to_have_attribute("aria-pressed", "true")
    assert background(page) == LIGHT_BG
    page.reload()
    assert background(page) == LIGHT_BG
    bar = page.locator("op-status-bar")
    assert bar.evaluate("e => getComputedStyle(e).backgroundColor") == "rgb(255, 255, 255)"
    page.get_by_test_id("nav-program").tap()
    workspace = page.locator("svg.blocklySvg").first
    expect(workspace).to_be_visible(timeout=30_000)
    assert workspace.evaluate("e => getComputedStyle(e).backgroundColor") == LIGHT_BG
    page.get_by_test_id("nav-system").tap()
    page.get_by_test_id("theme-dark").tap()
    assert background(page) == DARK_BG
    assert errors.errors == []


def test_a_pendant_named_by_its_user_is_the_name_others_see(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    page.goto(f"{runtime.url}/#/system")
    name = page.get_by_test_id("pendant-name")
    name.fill("Cell 2 pendant\u202e")  # a right-to-left override is dropped, not shown
    page.get_by_test_id("save-pendant-name").tap()
    expect(page.get_by_test_id("pendant-name-note")).to_contain_text('"Cell 2 pendant"')
    page.get_by_test_id("nav-jog").tap()
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control (Cell 2 pendant)")
    assert runtime.api("GET", "/devices/robot/lease").json()["holder"] == "Cell 2 pendant"
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("Nobody has control")


def test_the_system_panel_shows_the_runtimes_warnings(
    runtime: Runtime, robot: str, phone: BrowserContext, tmp_path: Path
) -> None:
    # A robot added, then gone: the device manager warns that it cannot reach it.
    sim = SimRobotProc(tmp_path, name="ghost-arm")
    sim.wait_ready()
    added = runtime.api("POST", "/devices", json={"url": sim.url, "local_name": "ghost"})
    assert added.status_code == 201, added.text
    wait_for(lambda: runtime.api("GET", "/devices/ghost").json()["status"] == "connected", 10)
    sim.stop()
    try:
        page = phone.new_page()
        page.goto(f"{runtime.url}/#/system")
        entry = page.get_by_test_id("log-entry").filter(has_text="ghost")
        expect(entry.first).to_be_visible(timeout=10_000)
        expect(entry.first).to_contain_text("device_manager")
        page.get_by_test_id("log-info").tap()
        expect(page.get_by_test_id("log-entry").filter(has_text="connected at")).not_to_have_count(
            0
        )
        assert fits_the_screen(page)
    finally:
        runtime.api("DELETE", "/devices/ghost")
