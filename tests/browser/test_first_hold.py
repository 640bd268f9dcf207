"""A newcomer's first hold (issue 32): a robot just added comes up at the site's first speed
override (10 %), and a one-second hold of J1 + on the Jog panel (the UR5 at home, its TCP
0.5 m from the axis) moves the TCP at most 35 mm (about 25 mm: the manual mode's 250 mm/s
cap, scaled); at 25 % the same hold moved it 80 mm, at 100 % 220 mm. A runtime of its own,
with the product's default (every other test runs its robots at 100 %)."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from playwright.sync_api import BrowserContext, expect

from openpendant.runtime.bench.harness.jog import RobotView
from openpendant.runtime.bench.harness.processes import FULL_SPEED_ENV, Runtime, wait_for
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.browser.conftest import (
    Finger,
    PageErrors,
    add_robot,
    browser_env,
    robot_at_rest,
)
from tests.browser.test_shop_floor import take_control_and_enable

UR5 = Kinematics(load_robot_info("ur5"))


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    home = tmp_path_factory.mktemp("first-hold")
    env = browser_env(home)
    for name in FULL_SPEED_ENV:  # the product's first speed, not the tests' full speed
        del env[name]
    proc = Runtime(home, env=env)
    proc.wait_ready()
    yield proc
    proc.stop()
    assert proc.service_errors() == []


def test_a_new_robots_first_hold_is_at_the_first_speed(
    runtime: Runtime, tablet: BrowserContext
) -> None:
    add_robot(runtime)
    page = tablet.new_page()
    errors = PageErrors(page)
    page.goto(f"{runtime.url}/#/jog")
    take_control_and_enable(page)
    expect(page.get_by_test_id("speed")).to_have_value("10")
    driver = RobotView(runtime)
    first = int(driver.setpoints(0)["seqno"][-1])
    finger = Finger(page)
    finger.down(page.locator("[data-testid=jog-row][data-axis='0'] [data-testid=jog-plus]"))
    try:
        time.sleep(1.5)  # the hold itself: a newcomer's first (the window measured is 1 s)
    finally:
        finger.up()
    wait_for(lambda: robot_at_rest(runtime), 5, what="stopped on release")
    # The TCP as the controller moved it, cycle by cycle, on its own clock: the most it
    # travelled in any one second, whatever the page's and this test's latencies.
    cycles = driver.setpoints(first)
    tcp = np.array([UR5.tcp(np.array(q)).translation for q in cycles["position"]])
    second = round(1.0 / cycles["cycle"])
    assert len(tcp) > second, "the hold lasted less than a second"
    travel = np.linalg.norm(tcp[second:] - tcp[:-second], axis=1)
    assert 0.005 < travel.max() <= 0.035, f"the TCP moved {travel.max() * 1000:.1f} mm in 1 s"
    page.get_by_test_id("control").tap()
    assert errors.errors == []


def test_a_robot_left_fast_elsewhere_is_slowed_where_it_first_comes_into_focus(
    runtime: Runtime, tablet: BrowserContext
) -> None:
    """Raised to 100 % by someone with control (another pendant, a script), the robot is
    lowered to the first speed by a pendant on which it first comes into focus, without
    that pendant taking control (lowering needs nobody's)."""
    add_robot(runtime)
    lease = runtime.api("POST", "/devices/robot/lease", json={"holder": "elsewhere"}).json()
    mine = {"X-Lease-Token": lease["token"]}
    raised = runtime.api("PUT", "/jog/robots/robot/speed", json={"ratio": 1.0}, headers=mine)
    assert raised.status_code == 200, raised.text
    try:
        page = tablet.new_page()
        errors = PageErrors(page)
        page.goto(f"{runtime.url}/#/jog")
        expect(page.get_by_test_id("speed")).to_have_value("10", timeout=10_000)
        wait_for(
            lambda: (
                abs(runtime.api("GET", "/devices/robot/state").json()["speed_ratio"] - 0.10) < 1e-9
            ),
            5,
            what="the robot at 10 %",
        )
        assert errors.errors == []
    finally:
        runtime.api("DELETE", "/devices/robot/lease", headers=mine)
