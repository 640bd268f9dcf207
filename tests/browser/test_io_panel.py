"""The I/O panel by touch, against a simulated Modbus I/O block on pymodbus's server: every
signal live, an input's change shown, an output switched only with control, and the page
fitting a phone."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Browser, BrowserContext, Locator, ViewportSize, expect

from openpendant.runtime.bench.harness.processes import DriverProc, Runtime
from tests.browser.conftest import TABLET, PageErrors, fits_the_screen, signed_in_context


@pytest.fixture(scope="module")
def block(runtime: Runtime) -> Iterator[str]:
    """A simulated cell I/O block, added as cell_io; its own URL (for the sensor's side)."""
    device = DriverProc(runtime.home, "modbus-io", "cell-io", "--simulate")
    try:
        url = device.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "cell_io"})
        assert added.status_code in (200, 201), added.text
        yield url
    finally:
        runtime.api("DELETE", "/devices/cell_io")
        device.stop()


def device_side(url: str, signal: str) -> bool | float:
    return httpx.get(f"{url}/sim/signals/{signal}", timeout=5).json()["value"]  # type: ignore[no-any-return]


def test_toggle_an_output_and_see_an_input_change(
    runtime: Runtime, block: str, tablet: BrowserContext
) -> None:
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/io")
    card = page.locator("[data-testid=io-block][data-name=cell_io]")
    expect(card).to_be_visible(timeout=15_000)
    part = page.get_by_test_id("signal-cell_io-part_present")
    expect(part).to_have_attribute("data-value", "false", timeout=10_000)
    expect(page.get_by_test_id("signal-cell_io-air_pressure")).to_contain_text("bar")

    # A sensor sees a part: the panel shows it.
    httpx.put(f"{block}/sim/signals/part_present", json={"value": True}, timeout=5)
    expect(part).to_have_attribute("data-value", "true")

    # Outputs are switched only with control of the block.
    lamp = page.get_by_test_id("toggle-cell_io-lamp_green")
    expect(lamp).to_be_disabled()
    page.get_by_test_id("io-control-cell_io").tap()
    expect(page.get_by_test_id("io-release-cell_io")).to_be_visible()
    expect(lamp).to_be_enabled()
    lamp.tap()
    expect(page.get_by_test_id("signal-cell_io-lamp_green")).to_have_attribute("data-value", "true")
    assert device_side(block, "lamp_green") is True
    lamp.tap()
    expect(page.get_by_test_id("signal-cell_io-lamp_green")).to_have_attribute(
        "data-value", "false"
    )
    assert device_side(block, "lamp_green") is False

    # An analog output, set in its unit and range.
    page.get_by_test_id("value-cell_io-feeder_speed").fill("42.5")
    page.get_by_test_id("value-cell_io-feeder_speed").press("Enter")
    expect(page.get_by_test_id("signal-cell_io-feeder_speed")).to_contain_text("42.5 %")
    assert device_side(block, "feeder_speed") == pytest.approx(42.5)

    page.get_by_test_id("io-release-cell_io").tap()
    expect(lamp).to_be_disabled()
    assert errors.errors == []


def test_the_io_panel_fits_a_phone(runtime: Runtime, block: str, phone: BrowserContext) -> None:
    page = phone.new_page()
    page.goto(f"{runtime.url}/#/io")
    expect(page.get_by_test_id("signal-cell_io-part_present")).to_be_visible(timeout=15_000)
    take = page.get_by_test_id("io-control-cell_io").bounding_box()
    assert take is not None and take["height"] >= 48
    expect(page.get_by_test_id("nav-io")).to_be_visible()
    assert fits_the_screen(page)


LONG_NAMES = {
    "conveyor_part_present_sensor_2": "discrete_input",
    "conveyor_belt_motor_forward_run": "coil",
    "conveyor_belt_speed_setpoint_pct": "holding_register",
}
NARROW_PHONE: ViewportSize = {"width": 360, "height": 740}
# Each line of a name as laid out: its characters grouped by the line box they sit on.
NAME_LINES = """el => {
  const lines = [];
  let top = null;
  const walker = document.createTreeWalker(el, NodeFilter.SHOW_TEXT);
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    for (let i = 0; i < node.data.length; i++) {
      const range = document.createRange();
      range.setStart(node, i);
      range.setEnd(node, i + 1);
      const box = range.getClientRects()[0];
      if (!box) continue;
      if (top === null || box.top > top + box.height / 2) {
        lines.push("");
        top = box.top;
      }
      lines[lines.length - 1] += node.data[i];
    }
  }
  return lines;
}"""


@pytest.fixture(scope="module")
def conveyor(runtime: Runtime, tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """A simulated I/O block whose signals have long names, added as conveyor_io."""
    home = tmp_path_factory.mktemp("conveyor-io")
    analog = ", type: uint16, scale: 0.1, unit: '%', minimum: 0, maximum: 100"
    signals = [
        f"  - {{name: {name}, table: {table}, address: 0{analog if 'reg' in table else ''}}}"
        for name, table in LONG_NAMES.items()
    ]
    signals.append("  - {name: in1, table: discrete_input, address: 1}")
    registers = home / "conveyor.yaml"
    head = "model: Conveyor I/O\nunit_id: 1\nbyte_order: big\nword_order: big\nsignals:\n"
    registers.write_text(head + "\n".join(signals) + "\n")
    device = DriverProc(home, "modbus-io", "conveyor-io", "--simulate", "--map", str(registers))
    try:
        url = device.wait_ready()
        added = runtime.api("POST", "/devices", json={"url": url, "local_name": "conveyor_io"})
        assert added.status_code in (200, 201), added.text
        yield
    finally:
        runtime.api("DELETE", "/devices/conveyor_io")
        device.stop()


def name_lines(signal: Locator) -> list[str]:
    lines: list[str] = signal.locator(".name").evaluate(NAME_LINES)
    return lines


@pytest.mark.parametrize("viewport", [TABLET, NARROW_PHONE], ids=["1280x800", "360-wide"])
def test_long_signal_names_wrap_between_their_words(
    runtime: Runtime,
    conveyor: None,
    browser: Browser,
    request: pytest.FixtureRequest,
    viewport: ViewportSize,
    artifacts: Path,
) -> None:
    """Issue 32: a long name beside its value and controls was squeezed to one letter a line.
    Every line of a name is a run of its words, broken after an underscore, and the name
    reads whole; with control taken (every control shown) too."""
    context = signed_in_context(browser, viewport, request)
    try:
        page = context.new_page()
        page.goto(f"{runtime.url}/#/io")
        take = page.get_by_test_id("io-control-conveyor_io")
        expect(take).to_be_visible(timeout=15_000)
        take.tap()
        expect(page.get_by_test_id("io-release-conveyor_io")).to_be_visible()
        for name in [*LONG_NAMES, "in1"]:
            signal = page.get_by_test_id(f"signal-conveyor_io-{name}")
            expect(signal).to_be_visible()
            lines = name_lines(signal)
            assert "".join(lines) == name, lines
            for line in lines[:-1]:
                assert line.endswith("_") and len(line) > 2, (viewport, lines)
            assert len(lines[-1]) > 1, (viewport, lines)
        assert len(name_lines(page.get_by_test_id("signal-conveyor_io-in1"))) == 1
        assert fits_the_screen(page)
        block = page.locator("[data-testid=io-block][data-name=conveyor_io]")
        block.screenshot(path=artifacts / f"io-long-names-{viewport['width']}.png")
        page.get_by_test_id("io-release-conveyor_io").tap()
        expect(take).to_be_visible()
    finally:
        context.close()
