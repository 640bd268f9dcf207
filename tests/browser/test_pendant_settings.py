"""This pendant's own settings on the System panel: a light theme for bright rooms (kept
across reloads, on every panel and in the block editor) and a name people chose, which
others see while it has control."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import BrowserContext, Page, expect

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, wait_for
from tests.browser.conftest import PageErrors, add_robot, fits_the_screen, robot_state

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
    added = runtime.api(
        "POST", "/devices", json={"url": sim.url, "local_name": "ghost", "pairing": sim.secret}
    )
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


# Every text node, label and hint a person sees on the page, shadow roots included; left out:
# the blocks (their words come from the block definitions, not the UI's catalogue) and what
# is marked translate="no" (names, the runtime's own messages, the brand).
SHOWN_TEXT = """() => {
  const found = [];
  const walk = (root) => {
    for (const el of root.querySelectorAll("*")) {
      const skip = "head, style, script, [translate=no], .blocklySvg, .blocklyToolbox, "
        + ".blocklyFlyout";
      if (el.closest(skip)) continue;
      for (const node of el.childNodes) {
        if (node.nodeType === Node.TEXT_NODE && node.textContent.trim()) {
          found.push(node.textContent.trim());
        }
      }
      for (const name of ["aria-label", "title", "placeholder"]) {
        if (el.getAttribute(name)) found.push(el.getAttribute(name));
      }
      if (el.shadowRoot) walk(el.shadowRoot);
    }
  };
  walk(document);
  return found;
}"""

# Each panel, and what shows once its first fetches have landed.
PANELS: dict[str, tuple[str, ...]] = {
    "jog": ("[data-testid=jog-row]",),
    "program": (".blocklyToolboxCategory",),
    "scene": ("[data-testid=tool-editor]",),
    "devices": ("[data-testid=device-card]",),
    "system": ("[data-testid=service]", "[data-testid=log], [data-testid=log-empty]"),
}
# The same in German, or data: robot and program names, units.
SAME_IN_BOTH = {"robot", "cycle", "STOP", "System", "Pause", "Details", "mm", "°", "kg", "3D"}
SAME_IN_BOTH |= {"Python", "Name", "Status", "Version", "in", "rad", "Plugins", "Export", "Import"}
SAME_IN_BOTH |= {f"TCP {axis} mm" for axis in "XYZ"}


def shown_words(page: Page) -> dict[str, set[str]]:
    """Per panel, the texts shown that have words in them."""
    shown: dict[str, set[str]] = {}
    for panel, loaded in PANELS.items():
        page.get_by_test_id(f"nav-{panel}").tap()
        for shown_once_loaded in loaded:
            expect(page.locator(shown_once_loaded).first).to_be_visible(timeout=30_000)
        texts = page.evaluate(SHOWN_TEXT)
        words = {t for t in texts if any(c.isalpha() for c in t) and len(t) > 1}
        shown[panel] = {t for t in words if not t.startswith("http")}  # addresses
    return shown


def toolbox_words(page: Page) -> dict[str, list[str]]:
    """Per toolbox category (as named), the text of each block and button in its flyout;
    each of them fits the screen."""
    page.get_by_test_id("nav-program").tap()
    categories = page.locator(".blocklyToolboxCategory")
    expect(categories.first).to_be_visible(timeout=30_000)
    screen = page.viewport_size
    assert screen is not None
    found: dict[str, list[str]] = {}
    for index in range(categories.count()):
        categories.nth(index).tap()
        items = page.locator(
            ".blocklyFlyout .blocklyBlockCanvas > g.blocklyDraggable, "
            ".blocklyFlyout .blocklyFlyoutButton"
        )
        expect(items.first).to_be_visible()
        texts = [(b.text_content() or "").replace("\xa0", " ") for b in items.all()]
        for item, text in zip(items.all(), texts, strict=True):
            box = item.bounding_box()
            assert box is not None and box["x"] + box["width"] <= screen["width"], text
        found[categories.nth(index).inner_text()] = texts
    return found


# The same in German (Blockly's words: "Text", "null", "sin" of 45), or no words at all.
SAME_BLOCKS = {"Text", "null", "π", "45sin"}


def test_the_blocks_speak_the_language_chosen_on_the_system_panel(
    runtime: Runtime, robot: str, phone: BrowserContext
) -> None:
    page = phone.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/program")
    english = toolbox_words(page)
    page.get_by_test_id("nav-system").tap()
    page.get_by_test_id("language-de").tap()
    german = toolbox_words(page)
    assert len(german) == len(english)
    for (en_name, en_blocks), (de_name, de_blocks) in zip(
        english.items(), german.items(), strict=True
    ):
        assert en_name != de_name or en_name in SAME_BLOCKS, en_name
        assert len(en_blocks) == len(de_blocks), en_name
        same = [
            text
            for text, translated in zip(en_blocks, de_blocks, strict=True)
            if text == translated and any(c.isalpha() for c in text)
        ]
        assert set(same) <= SAME_BLOCKS, (en_name, same)
    assert "PTP zu" in " ".join(german["Roboter"])
    assert errors.errors == []


def test_the_whole_ui_speaks_the_language_chosen_on_the_system_panel(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/system")
    english = shown_words(page)
    page.get_by_test_id("nav-system").tap()
    page.get_by_test_id("language-de").tap()
    expect(page.get_by_test_id("language-de")).to_have_attribute("aria-pressed", "true")
    assert page.evaluate("document.documentElement.lang") == "de"
    german = shown_words(page)
    page.get_by_test_id("nav-program").tap()
    tabs = page.get_by_role("tab")  # the longest names, on a tablet's narrow side column
    expect(tabs).to_have_count(4)
    clipped = tabs.evaluate_all("els => els.filter(e => e.scrollWidth > e.clientWidth)")
    assert clipped == [], "a tab's name does not fit it"
    page.get_by_test_id("nav-system").tap()
    for panel in PANELS:
        untranslated = (english[panel] & german[panel]) - SAME_IN_BOTH
        assert not untranslated, (panel, sorted(untranslated)[:80])
        assert german[panel] - english[panel], panel  # something is shown in German
    page.reload()  # kept on this tablet
    expect(page.get_by_test_id("language-de")).to_have_attribute("aria-pressed", "true")
    page.get_by_test_id("language-en").tap()
    assert shown_words(page)["system"] == english["system"]
    assert errors.errors == []


def test_lengths_and_angles_read_and_are_typed_in_the_units_chosen(
    runtime: Runtime, robot: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    readout = page.get_by_test_id("tcp-readout")
    expect(readout).to_contain_text("X mm")
    x, _, z = robot_state(runtime)["tcp_pose"]["position"]

    def shown() -> list[float] | None:
        words = readout.inner_text().split()  # "X in <x> Y in <y> Z in <z> Roll rad …"
        try:
            return [float(words[i]) for i in (2, 5, 8, 11)]
        except (IndexError, ValueError):
            return None  # "–" until the robot's state has come

    page.get_by_test_id("nav-system").tap()
    page.get_by_test_id("units-length-in").tap()
    page.get_by_test_id("units-angle-rad").tap()
    page.get_by_test_id("nav-jog").tap()
    expect(readout).to_contain_text("X in")
    expect(readout).to_contain_text("Roll rad")
    inches: list[float] = wait_for(shown, 10, what="the TCP readout")
    assert abs(inches[0] - x / 0.0254) < 0.002 and abs(inches[2] - z / 0.0254) < 0.002
    assert abs(inches[3]) <= 3.1425  # roll in radians (±π, to 3 places), not degrees
    rows = page.get_by_test_id("jog-row")
    expect(rows.first).to_contain_text("rad")  # drawn once the robot's model has loaded
    assert "°" not in " ".join(rows.all_inner_texts())

    # A TCP typed in inches is stored in metres.
    page.get_by_test_id("control").tap()
    expect(page.get_by_test_id("lease")).to_contain_text("You have control")
    page.get_by_test_id("nav-scene").tap()
    field = page.get_by_test_id("tool-z")
    field.fill("4")
    field.dispatch_event("change")
    page.get_by_test_id("save-tool").tap()
    expect(page.get_by_test_id("tool-saved")).to_be_visible()
    stored = runtime.api("GET", "/variables/tools.robot").json()["value"]
    assert abs(stored["tcp"]["position"][2] - 4 * 0.0254) < 1e-9
    page.reload()  # the units are kept, and the field reads back what was typed
    expect(page.get_by_test_id("tool-z")).to_have_value("4")
    field = page.get_by_test_id("tool-z")
    field.fill("0")
    field.dispatch_event("change")
    page.get_by_test_id("save-tool").tap()
    expect(page.get_by_test_id("tool-saved")).to_be_visible()
    assert errors.errors == []
