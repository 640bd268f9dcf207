"""A page left open while the runtime stops shows that nothing is known (no green chips, no
tappable Enable, no made-up readings) and, once the runtime is back, is usable again by
itself: no reload, no tab switch."""

from __future__ import annotations

import time
from pathlib import Path

from playwright.sync_api import Browser, BrowserContext, Route, expect

from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from tests.browser.conftest import (
    BROWSER_DEADMAN,
    TABLET,
    PageErrors,
    add_robot,
    open_context,
    robot_joints,
    sign_in,
)
from tests.browser.test_shop_floor import hold, take_control_and_enable

BACK_WITHIN = 5.0  # s after the runtime answers again: what a technician would wait


def test_the_jog_page_is_usable_again_after_the_runtime_restarts(
    browser: Browser, tmp_path: Path
) -> None:
    env = child_env(tmp_path, OPENPENDANT_DEADMAN_SECONDS=str(BROWSER_DEADMAN))
    first = Runtime(tmp_path, env=env)
    first.wait_ready()
    context = open_context(browser, TABLET)
    sign_in(context, first)  # kept by the runtime's data: the restarted one knows it too
    second: Runtime | None = None
    try:
        add_robot(first)
        page = context.new_page()
        page.goto(f"{first.url}/#/jog")
        view = page.get_by_test_id("robot-view")
        expect(view).to_have_attribute("data-status", "ready", timeout=30_000)
        expect(page.locator("[data-testid=jog-row]")).to_have_count(6)
        take_control_and_enable(page)

        first.stop()
        link = page.get_by_test_id("runtime-link")
        expect(link).to_contain_text("No connection")
        robot_chip = page.locator("[data-testid=status-robot][data-name=robot]")
        expect(robot_chip).to_contain_text("unknown")
        expect(page.get_by_test_id("enable")).to_be_disabled()  # its state is not known
        expect(page.get_by_test_id("tcp-readout")).not_to_contain_text("0.0")
        expect(page.get_by_test_id("deadman")).to_contain_text("link down")

        second = Runtime(tmp_path, port=first.port, env=env)
        second.wait_ready()
        healthy = time.monotonic()
        assert second.api("GET", "/health").status_code == 200
        expect(link).to_have_text("Runtime connected", timeout=BACK_WITHIN * 1000)
        expect(robot_chip).not_to_contain_text("unknown", timeout=BACK_WITHIN * 1000)
        expect(view).to_have_attribute("data-status", "ready", timeout=BACK_WITHIN * 1000)
        expect(view).to_have_attribute("data-robot", "robot")
        expect(page.locator("[data-testid=jog-row]")).to_have_count(6)
        expect(page.get_by_test_id("tcp-readout")).to_contain_text("mm")
        expect(page.get_by_test_id("deadman")).not_to_contain_text("link down")
        back_in = time.monotonic() - healthy
        assert back_in < BACK_WITHIN, f"usable {back_in:.1f} s after the runtime's health"

        # Usable means it jogs. The lease outlived the restart (leases are kept on disk); the
        # restarted robot is powered off.
        expect(page.get_by_test_id("lease")).to_contain_text("You have control")
        page.get_by_test_id("enable").tap()
        expect(page.get_by_test_id("disable")).to_be_enabled()
        before = robot_joints(second)
        hold(page, 0, 0.8)
        wait_for(lambda: abs(robot_joints(second)[0] - before[0]) > 1e-3, 5, what="J1 moved")
    finally:
        context.close()
        if second is not None:
            second.stop()
        first.stop()


def test_control_is_kept_through_a_renewal_the_runtime_could_not_answer(
    runtime: Runtime, tablet: BrowserContext
) -> None:
    # While the runtime restarts, a renewal meets a gateway whose device manager is not up
    # yet (503). The lease is alive (leases outlive restarts): the tablet keeps it.
    add_robot(runtime)
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    page.get_by_test_id("control").tap()
    lease = page.get_by_test_id("lease")
    expect(lease).to_contain_text("You have control")

    def unavailable(route: Route) -> None:
        body = {"error": {"code": "service_unavailable", "message": "not responding"}}
        route.fulfill(status=503, json=body)

    page.route("**/api/devices/robot/lease", unavailable)
    with page.expect_response(
        lambda r: r.url.endswith("/lease") and r.status == 503, timeout=12_000
    ):
        pass  # the next renewal (every 5 s) meets the 503
    page.unroute("**/api/devices/robot/lease")
    expires = runtime.api("GET", "/devices/robot/lease").json()["expires"]
    wait_for(
        lambda: (runtime.api("GET", "/devices/robot/lease").json()["expires"] or 0) > expires,
        12,
        what="the next renewal",
    )
    expect(lease).to_contain_text("You have control")
    page.get_by_test_id("control").tap()
    expect(lease).to_contain_text("Nobody has control")
    assert [e for e in errors.errors if "503" not in e] == []
