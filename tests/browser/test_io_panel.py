"""The I/O panel by touch, against a simulated Modbus I/O block on pymodbus's server: every
signal live, an input's change shown, an output switched only with control, and the page
fitting a phone."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest
from playwright.sync_api import BrowserContext, expect

from runtime.bench.harness.processes import DriverProc, Runtime
from tests.browser.conftest import PageErrors, fits_the_screen


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
