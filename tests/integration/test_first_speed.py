"""A robot's speed override starts at the site's first speed (`link.first_speed_ratio`, 10 %
by default) whenever its link comes up: when it is added, when its link comes back after a
loss, and when the runtime starts again (issue 32: a newcomer's first one-second hold at
100 % moved the TCP 127 mm). Lowering it is anyone's; raising it needs control, as before."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from openpendant.runtime.bench.harness.processes import (
    FULL_SPEED_ENV,
    Runtime,
    SimRobotProc,
    child_env,
    wait_for,
)

FIRST = 0.10  # the site's default


def with_defaults(home: Path) -> Runtime:
    env = child_env(home)
    for name in FULL_SPEED_ENV:  # the tests' full speed: this test is about the default
        del env[name]
    return Runtime(home, extra=["--no-sim"], env=env)


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[SimRobotProc]:
    """A simulated robot of its own: it keeps its speed override while runtimes come and go."""
    sim = SimRobotProc(tmp_path / "robot", name="first-speed-robot")
    try:
        sim.wait_ready()
        yield sim
    finally:
        sim.stop()


def speed(runtime: Runtime) -> float:
    state: dict[str, Any] = runtime.api("GET", "/devices/robot/state").json()
    return float(state.get("speed_ratio", -1.0))


def at_first_speed(runtime: Runtime, what: str) -> None:
    wait_for(lambda: abs(speed(runtime) - FIRST) < 1e-9, 15, what=what)


def raised(runtime: Runtime) -> None:
    lease = runtime.api("POST", "/devices/robot/lease", json={"holder": "tests"}).json()["token"]
    mine = {"X-Lease-Token": lease}
    answer = runtime.api("PUT", "/jog/robots/robot/speed", json={"ratio": 1.0}, headers=mine)
    assert answer.status_code == 200, answer.text
    assert answer.json()["speed_ratio"] == pytest.approx(1.0)
    runtime.api("DELETE", "/devices/robot/lease", headers=mine)


def test_a_robot_comes_up_at_the_first_speed_added_back_and_after_a_restart(
    tmp_path: Path, robot: SimRobotProc
) -> None:
    home = tmp_path / "runtime"
    runtime = with_defaults(home)
    try:
        runtime.wait_ready()
        pairing = {"url": robot.url, "local_name": "robot", "pairing": robot.secret}
        added = runtime.api("POST", "/devices", json=pairing)
        assert added.status_code == 201, added.text
        at_first_speed(runtime, "10 % once added")
        # Raising it needs control; lowering it does not.
        refused = runtime.api("PUT", "/jog/robots/robot/speed", json={"ratio": 1.0})
        assert refused.status_code == 409, refused.text
        assert refused.json()["error"]["code"] == "lease_required"
        assert speed(runtime) == pytest.approx(FIRST)
        raised(runtime)

        # The link lost and back: the robot's process frozen past the stale limit.
        os.kill(robot.pid, signal.SIGSTOP)
        try:
            wait_for(
                lambda: runtime.api("GET", "/devices/robot").json()["status"] != "connected",
                10,
                what="the link lost",
            )
        finally:
            os.kill(robot.pid, signal.SIGCONT)
        at_first_speed(runtime, "10 % once the link is back")
        raised(runtime)
    finally:
        runtime.stop()

    # The runtime started again: its link to the robot (which kept 100 %) comes up anew.
    again = with_defaults(home)
    try:
        again.wait_ready()
        at_first_speed(again, "10 % after the runtime's restart")
    finally:
        again.stop()
