"""A plugin, installed with pip and nothing of the core edited: its device is discovered and
added in the Devices panel, its panel shows and runs it by touch, its blocks are in the
toolbox and run in a program. Uninstalled, the runtime starts without it; a plugin that
fails to load is shown on the System panel while the rest runs."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import BrowserContext, expect

from openpendant.runtime.bench.harness.blocks import block, number, stack, text, workspace
from openpendant.runtime.bench.harness.processes import DriverProc, Runtime, wait_for
from tests.browser.conftest import (
    PageErrors,
    browser_env,
    sign_in,
)

ROOT = Path(__file__).resolve().parents[2]
PLUGIN = ROOT / "plugins" / "conveyor"
DISTRIBUTION = "openpendant-conveyor"
PIP = [sys.executable, "-m", "pip"]


def pip(*args: str) -> None:
    subprocess.run([*PIP, *args], check=True, capture_output=True, timeout=300)


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("plugins")


@pytest.fixture(scope="module")
def installed() -> Iterator[None]:
    """`pip install ./plugins/conveyor` into this environment, the runtime's own."""
    pip("install", "--quiet", "--no-deps", "--no-build-isolation", str(PLUGIN))
    try:
        yield
    finally:
        pip("uninstall", "--yes", "--quiet", DISTRIBUTION)


def start_runtime(home: Path, **extra: str) -> Runtime:
    runtime = Runtime(home, env=browser_env(home, **extra))
    runtime.wait_ready()
    return runtime


@pytest.fixture(scope="module")
def belt(installed: None, home: Path) -> Iterator[DriverProc]:
    """A simulated conveyor, started as any installed driver is: `openpendant driver`."""
    proc = DriverProc(home, "sim-conveyor", "belt-1", "--sensor-at", "0.3", "--spacing", "0.2")
    proc.wait_ready()
    yield proc
    proc.stop()


def conveyor_state(runtime: Runtime) -> dict[str, Any]:
    return runtime.api("GET", "/devices/belt/state").json()  # type: ignore[no-any-return]


def feeding_program() -> dict[str, Any]:
    """Run the belt until a part reaches the sensor, stop it, say so."""
    return workspace(
        stack(
            block("conveyor_run", {"CONVEYOR": "belt"}, SPEED=number(300)),
            block("conveyor_wait_part", {"CONVEYOR": "belt"}, TIMEOUT=number(10)),
            block("conveyor_run", {"CONVEYOR": "belt"}, SPEED=number(0)),
            block("text_print", None, TEXT=text("a part is at the sensor")),
        )
    )


def test_an_installed_plugin_adds_a_device_a_panel_and_blocks(
    installed: None, belt: DriverProc, home: Path, tablet: BrowserContext
) -> None:
    drivers = subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", "driver", "--list"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "sim-conveyor" in drivers
    runtime = start_runtime(home)
    try:
        sign_in(tablet, runtime)
        page = tablet.new_page()
        errors = PageErrors(page)

        # Discovered and added in the Devices panel, like any device.
        page.goto(f"{runtime.url}/#/devices")
        card = page.get_by_test_id("detected-device").filter(has_text="belt-1")
        expect(card).to_be_visible(timeout=15_000)
        expect(card).to_contain_text("conveyor")
        card.get_by_test_id("add-device").tap()
        page.get_by_test_id("local-name").fill("belt")
        page.get_by_test_id("confirm-add").tap()
        added = page.get_by_test_id("device-card").filter(has_text="belt")
        expect(added.get_by_test_id("device-status")).to_have_text("Connected", timeout=15_000)

        # Its panel: run the belt by touch until a part waits at the sensor, then stop it.
        page.get_by_test_id("nav-conveyor").tap()
        conveyor = page.get_by_test_id("conveyor").filter(has_text="belt")
        expect(conveyor).to_be_visible()
        expect(conveyor.get_by_test_id("conveyor-run")).to_be_disabled()  # no control yet
        conveyor.get_by_test_id("conveyor-take").tap()
        expect(conveyor.get_by_test_id("conveyor-run")).to_be_enabled()
        conveyor.get_by_test_id("conveyor-speed-input").fill("400")
        conveyor.get_by_test_id("conveyor-run").tap()
        expect(conveyor.get_by_test_id("conveyor-speed")).to_have_text("400 mm/s")
        expect(conveyor.get_by_test_id("conveyor-part")).to_have_attribute(
            "data-present", "true", timeout=10_000
        )
        # The pendant's STOP stops it too, whatever panel is shown.
        page.get_by_test_id("safety-stop").tap()
        expect(conveyor.get_by_test_id("conveyor-speed")).to_have_text("0 mm/s")
        conveyor.get_by_test_id("conveyor-speed-input").fill("50")
        conveyor.get_by_test_id("conveyor-run").tap()
        expect(conveyor.get_by_test_id("conveyor-speed")).to_have_text("50 mm/s")
        conveyor.get_by_test_id("conveyor-stop").tap()
        expect(conveyor.get_by_test_id("conveyor-speed")).to_have_text("0 mm/s")
        # Control stays with this tablet: its program runs under the lease the panel took.

        # The waiting part is taken away: the program must bring the next one.
        httpx.post(f"{belt.url}/sim/take").raise_for_status()
        wait_for(lambda: not conveyor_state(runtime)["part_present"], 5, what="part taken")

        # Its blocks: in the toolbox, and a program made of them runs.
        saved = runtime.api("PUT", "/programs/feed", json={"workspace": feeding_program()})
        assert saved.status_code == 200, saved.text
        page.get_by_test_id("nav-program").tap()
        page.get_by_test_id("program-select").select_option("feed")
        page.locator(".blocklyToolboxCategory", has_text="Conveyor").tap()
        flyout = page.locator(".blocklyFlyout .blocklyBlockCanvas > g.blocklyDraggable")
        expect(flyout).to_have_count(2)
        expect(flyout.first).to_contain_text("run conveyor")
        page.get_by_test_id("tab-python").tap()
        expect(page.get_by_test_id("python")).to_contain_text("wait_for_part('belt', 10)")
        page.get_by_test_id("run").tap()
        expect(page.get_by_test_id("run-state")).to_have_text("finished", timeout=30_000)
        status = runtime.api("GET", "/programs/feed/status").json()
        assert [o["text"] for o in status["output"]] == ["a part is at the sensor"]
        state = conveyor_state(runtime)
        assert state["part_present"] and state["parts_taken"] == 1
        wait_for(lambda: conveyor_state(runtime)["speed"] == 0.0, 5, what="the belt stopped")

        # The System panel names the plugin and what it adds.
        page.get_by_test_id("nav-system").tap()
        row = page.get_by_test_id("plugin").filter(has_text="conveyor")
        expect(row).to_contain_text(f"{DISTRIBUTION} 0.1.0")
        expect(row).to_contain_text("sim-conveyor")
        expect(page.get_by_test_id("plugin-failure")).to_have_count(0)
        assert errors.errors == []
        # Left before the runtime stops, as a tablet would be: a proxied request still open
        # when it stopped outlasted the gateway's 3 s graceful shutdown once (logged as an
        # error).
        page.close()
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


def broken_plugin(folder: Path) -> Path:
    """A plugin whose module fails to import, installed on PYTHONPATH only."""
    dist = folder / "broken_plugin-0.1.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        "[openpendant.plugins]\nbroken = openpendant_broken_plugin:PLUGIN\n"
    )
    (folder / "openpendant_broken_plugin.py").write_text(
        "raise ImportError('the vendor SDK is not installed')\n"
    )
    return folder


def test_uninstalled_it_is_gone_and_a_broken_plugin_leaves_the_rest_running(
    installed: None, belt: DriverProc, home: Path, tablet: BrowserContext
) -> None:
    pip("uninstall", "--yes", "--quiet", DISTRIBUTION)
    extra = broken_plugin(home / "broken")
    # The same data directory: the conveyor added before stays added, and harms nothing.
    runtime = start_runtime(home, PYTHONPATH=str(extra))
    try:
        assert runtime.api("GET", "/health").json()["status"] == "ok"
        report = runtime.api("GET", "/plugins").json()
        assert "conveyor" not in {p["name"] for p in report["plugins"]}
        assert [f["plugin"] for f in report["failures"]] == ["broken"]
        # The belt still announces itself, but nothing installed knows conveyors now.
        assert all(d["kind"] != "conveyor" for d in runtime.api("GET", "/devices/detected").json())

        sign_in(tablet, runtime)
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/system")
        failure = page.get_by_test_id("plugin-failure")
        expect(failure).to_contain_text("the vendor SDK is not installed")
        expect(page.get_by_test_id("nav-conveyor")).to_have_count(0)
        expect(page.get_by_test_id("nav-jog")).to_be_visible()
        page.get_by_test_id("nav-program").tap()
        expect(page.locator(".blocklyToolboxCategory", has_text="Robot")).to_be_visible()
        expect(page.locator(".blocklyToolboxCategory", has_text="Conveyor")).to_have_count(0)
        assert errors.errors == []
    finally:
        runtime.stop()
