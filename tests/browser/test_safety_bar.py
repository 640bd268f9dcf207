"""The safety bar (issue 32): STOP, the speed override and the robot chips stay inside the
viewport on a tablet and on phones with twelve navigation entries, whatever panel is shown,
however far it, the navigation or the page is scrolled; STOP tapped there halts a moving
robot. On a phone no panel is wider than the screen and the bar takes under 15 % of its
height. A robot's chip says its link's state first: a stale link is *Stale*, in red, not
the mode it was last in."""

from __future__ import annotations

import os
import re
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from playwright.sync_api import Browser, BrowserContext, Locator, Page, ViewportSize, expect

from openpendant.runtime.bench.harness.processes import STILL, Runtime, SimRobotProc, wait_for
from tests.browser.conftest import (
    PHONE,
    TABLET,
    PageErrors,
    browser_env,
    fits_the_screen,
    open_context,
    robot_at_rest,
    robot_joints,
    sign_in,
)

NARROW: ViewportSize = {"width": 360, "height": 800}
SCREENS = {"tablet": TABLET, "phone": PHONE, "narrow phone": NARROW}
ENTRIES = 12  # the eight built-in panels an administrator sees and the plugin's four
LONG_PANELS = 4
BAR_SHARE = 0.15  # of a phone's height

# A plugin with four long panels, installed on PYTHONPATH as the plugin tests install one:
# with them an administrator's navigation has twelve entries, and each panel scrolls.
PLUGIN_SOURCE = f"""
from openpendant.plugins.api import Panel, Plugin

PLUGIN = Plugin(
    name="long-panels",
    description="Four long panels (a browser test's)",
    panels=tuple(
        Panel(
            id=f"long-{{i}}",
            package="openpendant_long_panels",
            module="web/long.js",
            element="op-long-test-panel",
            title={{"en": f"Long {{i}}", "de": f"Lang {{i}}"}},
            icon="M4 4h16v16H4z",
            order=80 + i,
        )
        for i in range(1, {LONG_PANELS + 1})
    ),
)
"""

PANEL_MODULE = """
class LongPanel extends HTMLElement {
  connectedCallback() {
    if (this.shadowRoot) return;
    const root = this.attachShadow({ mode: "open" });
    const rows = [];
    for (let i = 1; i <= 40; i++) {
      rows.push(`<p style="min-height: 90px; margin: 0 0 12px; border: 1px solid var(--line)">` +
        `Row ${i}</p>`);
    }
    root.innerHTML = `<h2>A long panel</h2>${rows.join("")}<p data-testid="long-end">End</p>`;
  }
}
if (!customElements.get("op-long-test-panel")) {
  customElements.define("op-long-test-panel", LongPanel);
}
"""


def long_panels_plugin(folder: Path) -> Path:
    package = folder / "openpendant_long_panels"
    (package / "web").mkdir(parents=True)
    (package / "__init__.py").write_text(PLUGIN_SOURCE)
    (package / "web" / "long.js").write_text(PANEL_MODULE)
    dist = folder / "long_panels-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: long-panels\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        "[openpendant.plugins]\nlong-panels = openpendant_long_panels:PLUGIN\n"
    )
    return folder


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    """A runtime with the long panels and no simulated robot of its own: the robot is a
    process of the test's (frozen by the stale-link test)."""
    home = tmp_path_factory.mktemp("safety-bar")
    paths = [str(long_panels_plugin(home / "plugin")), os.environ.get("PYTHONPATH", "")]
    env = browser_env(home, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    proc = Runtime(home, extra=["--no-sim"], env=env)
    proc.wait_ready()
    yield proc
    proc.stop()
    assert proc.service_errors() == []


@pytest.fixture(scope="module")
def sim(runtime: Runtime) -> Iterator[SimRobotProc]:
    """A simulated UR5, added as `robot`."""
    robot = SimRobotProc(runtime.home, name="safety-bar-robot")
    try:
        robot.wait_ready()
        pairing = {"url": robot.url, "local_name": "robot", "pairing": robot.secret}
        added = runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        wait_for(lambda: status(runtime) == "connected", 15, what="the robot connected")
        yield robot
    finally:
        robot.stop()


def status(runtime: Runtime) -> str:
    return str(runtime.api("GET", "/devices/robot").json()["status"])


@pytest.fixture
def screen(
    browser: Browser, runtime: Runtime, request: pytest.FixtureRequest
) -> Iterator[BrowserContext]:
    context = open_context(browser, SCREENS[request.param])
    sign_in(context, runtime)
    yield context
    context.close()


def on_screen(page: Page, target: Locator) -> bool:
    """Its whole box inside the window."""
    box = target.bounding_box()
    size = page.viewport_size
    assert size is not None
    return (
        box is not None
        and box["x"] >= 0
        and box["y"] >= 0
        and box["x"] + box["width"] <= size["width"]
        and box["y"] + box["height"] <= size["height"]
    )


def scroll_everything_to_the_end(page: Page) -> None:
    """The panel, the navigation and the page itself scrolled as far as each goes, as a
    finger or a focused control could."""
    at_end: bool = page.evaluate(
        """() => {
            const shell = document.querySelector('op-app').shadowRoot;
            const main = shell.querySelector('main');
            for (const box of [main, shell.querySelector('nav'), document.scrollingElement]) {
                box.scrollTo(box.scrollWidth, box.scrollHeight);
            }
            window.scrollTo(document.body.scrollWidth, document.body.scrollHeight);
            return main.scrollTop + main.clientHeight >= main.scrollHeight - 1;
        }"""
    )
    assert at_end


def the_bar_is_on_screen(page: Page, where: str) -> None:
    for part in ("safety-stop", "speed", "status-robot"):
        assert on_screen(page, page.get_by_test_id(part).first), (where, part)


def the_phone_layout_fits(page: Page, where: str) -> None:
    size = page.viewport_size
    assert size is not None
    bar = page.locator("op-status-bar").bounding_box()
    assert bar is not None
    assert bar["height"] < BAR_SHARE * size["height"], (where, bar["height"])
    layout: dict[str, float] = page.evaluate(
        """() => {
            const main = document.querySelector('op-app').shadowRoot.querySelector('main');
            const panel = main.firstElementChild.getBoundingClientRect();
            return {panel: panel.right, scroll: main.scrollWidth, client: main.clientWidth};
        }"""
    )
    assert layout["panel"] <= size["width"], (where, layout)
    assert layout["scroll"] <= layout["client"], (where, layout)
    assert fits_the_screen(page), where


def start_a_long_move(runtime: Runtime, lease: dict[str, str]) -> tuple[str, np.ndarray[Any, Any]]:
    enabled = runtime.api("POST", "/jog/robots/robot/enable", headers=lease)
    assert enabled.status_code == 200, enabled.text
    goal = robot_joints(runtime)
    goal[0] += -0.8 if goal[0] > 0 else 0.8  # the base turns, away from its limit
    # Slowly (a few seconds), so it is still on its way when STOP is tapped.
    request = {"kind": "joint", "target": {"joints": goal.tolist()}, "speed": 0.1}
    started = runtime.api("POST", "/motion/robots/robot/moves", json=request, headers=lease)
    assert started.status_code == 202, started.text
    wait_for(lambda: not robot_at_rest(runtime), 10, what="the robot moving")
    return str(started.json()["id"]), goal


@pytest.mark.parametrize("screen", list(SCREENS), indirect=True)
def test_stop_stays_on_screen_with_twelve_panels_and_halts_the_robot(
    runtime: Runtime, sim: SimRobotProc, screen: BrowserContext, request: pytest.FixtureRequest
) -> None:
    phone = request.node.callspec.params["screen"] != "tablet"
    page = screen.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    expect(page.get_by_test_id(f"nav-long-{LONG_PANELS}")).to_be_attached(timeout=15_000)
    expect(page.get_by_test_id("status-robot")).to_contain_text("robot")
    entries = page.locator("[data-testid^=nav-]")
    # Twelve, or one more while another module has the example conveyor plugin installed.
    assert entries.count() >= ENTRIES
    ids = [entries.nth(i).get_attribute("data-testid") or "" for i in range(entries.count())]
    # Every panel in turn, the last entries last: each tapped (a tap first brings its entry
    # into view), then everything scrolled to its end.
    for entry in ids:
        page.get_by_test_id(entry).tap()
        expect(page.get_by_test_id(entry)).to_have_attribute("aria-current", "page")
        if entry.startswith("nav-long-"):
            expect(page.get_by_test_id("long-end")).to_be_attached()
        scroll_everything_to_the_end(page)
        the_bar_is_on_screen(page, entry)
        if phone:
            the_phone_layout_fits(page, entry)

    # Still on the last panel, scrolled to its end: a move under way is halted by STOP.
    token = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]
    lease = {"X-Lease-Token": token}
    try:
        move, goal = start_a_long_move(runtime, lease)
        stop = page.get_by_test_id("safety-stop")
        assert on_screen(page, stop)
        stop.tap()
        wait_for(lambda: robot_at_rest(runtime), 3, what="the robot halted by STOP")
        ended = wait_for(
            lambda: (lambda s: s if s["state"] not in ("planning", "running") else None)(
                runtime.api("GET", f"/motion/moves/{move}").json()
            ),
            5,
            what="the move ended",
        )
        assert ended["state"] != "finished", ended
        held = robot_joints(runtime)
        assert np.abs(held - goal).max() > 0.1  # halted on the way, not arrived
        wait_for(lambda: robot_at_rest(runtime), 3, what="the robot still")
        assert np.abs(robot_joints(runtime) - held).max() < STILL  # and nothing resumed
    finally:
        runtime.api("DELETE", "/devices/robot/lease", headers=lease)
    the_bar_is_on_screen(page, "after STOP")
    assert errors.errors == []


def css_colour(page: Page, variable: str) -> str:
    """A palette colour (a #rrggbb custom property of the page) as computed styles give it."""
    value: str = page.evaluate(
        "(name) => getComputedStyle(document.documentElement).getPropertyValue(name).trim()",
        variable,
    )
    match = re.fullmatch(r"#([0-9a-fA-F]{2})([0-9a-fA-F]{2})([0-9a-fA-F]{2})", value)
    assert match, value
    red, green, blue = (int(part, 16) for part in match.groups())
    return f"rgb({red}, {green}, {blue})"


def test_a_stale_link_turns_the_chip_to_stale_before_its_mode(
    runtime: Runtime, sim: SimRobotProc, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    chip = page.locator("[data-testid=status-robot][data-name=robot]")
    expect(chip).to_contain_text("Manual", timeout=15_000)
    bad = css_colour(page, "--bad-bg")
    expect(chip).not_to_have_css("background-color", bad)

    # The robot's process frozen: its states stop, and the runtime calls its link stale.
    os.kill(sim.pid, signal.SIGSTOP)
    try:
        wait_for(lambda: status(runtime) == "stale", 10, interval=0.02, what="the link stale")
        # The chip follows its link at once (0.5 s for the page to be told and draw it).
        expect(chip).to_contain_text(re.compile(r"\bStale\b"), timeout=500)
        expect(chip).not_to_contain_text("Manual")
        expect(chip).to_have_css("background-color", bad)
        # The Jog panel's card and the chip say the same.
        expect(page.get_by_test_id("robot-fault")).to_have_attribute("data-kind", "link")
    finally:
        os.kill(sim.pid, signal.SIGCONT)
    # Back: its mode again, and no longer red.
    wait_for(lambda: status(runtime) == "connected", 15, what="the link back")
    expect(chip).to_contain_text("Manual", timeout=10_000)
    expect(chip).not_to_have_css("background-color", bad)
    failed = [e for e in errors.errors if not e.startswith("Failed to load resource")]
    assert failed == []
