"""A runtime process killed (kill -9) while the robot moves: the robot halts within 0.2 s,
measured at the driver (its command log and its 2 ms setpoints), and nothing resumes when
the launcher has restarted the process. Every command path to a driver runs over the device
manager's one link: a service whose link socket closes leaves nothing moving, and a device
manager that dies closes the driver's session."""

from __future__ import annotations

import math
import os
import random
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for

HALT_WITHIN = 0.2  # s from the kill to the halt at the driver (the bound)
HEALTHY_AFTER = 0.5  # s up after which a restarted service counts as healthy (the least)
FAR = [2.5, -1.0, 1.2, -1.5, -1.57, 1.0]
FAR_DEGREES = [round(math.degrees(v), 6) for v in FAR]


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    home = tmp_path_factory.mktemp("faults")
    # Killed again and again, the program service is restarted at once each time: the
    # launcher doubles its wait after each exit of a process that was up for less than
    # HEALTHY_AFTER (the fifty kills wait for that).
    env = child_env(
        home,
        OPENPENDANT_RESTART_HEALTHY_AFTER=str(HEALTHY_AFTER),
        OPENPENDANT_RESTART_BACKOFF="0.05",
    )
    runtime = Runtime(home, env=env)
    runtime.wait_ready()
    try:
        yield Cell(runtime)
    finally:
        runtime.stop()


@pytest.fixture
def ready(cell: Cell) -> Cell:
    wait_for(lambda: healthy(cell), 60, what="every service up")
    wait_for(
        lambda: cell.runtime.api("GET", "/devices/robot").json()["status"] == "connected",
        10,
        what="the robot's link",
    )
    cell.ready()
    cell.robot.wait_stopped()
    if abs(cell.robot.q()[0]) > 0.2:
        cell.place([0.0, *FAR[1:]])
    return cell


def healthy(cell: Cell) -> bool:
    services = cell.runtime.api("GET", "/health").json()["services"]
    return all(s.get("status") == "ok" for s in services.values())


def children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def kill(cell: Cell, service: str) -> float:
    pid = int(cell.runtime.api("GET", "/health").json()["services"][service]["pid"])
    os.kill(pid, signal.SIGKILL)
    return time.time()


def halted_after(cell: Cell, killed: float, before: int) -> float:
    """Seconds from the kill to the driver's halt."""
    log = wait_for(
        lambda: [c for c in cell.robot.commands(before) if c["type"] == "halt"],
        5,
        what="a halt at the driver",
    )
    return float(log[0]["t"]) - killed


def moving(cell: Cell) -> bool:
    return bool(np.abs(cell.robot.state()["joint_velocity"]).max() > 0.05)


def assert_stays_still(cell: Cell) -> None:
    cell.robot.wait_stopped(3)
    q = cell.robot.q()
    time.sleep(1.0)
    assert np.abs(cell.robot.q() - q).max() < 1e-6  # nothing resumed


def start_slow_move(cell: Cell) -> dict[str, Any]:
    request = {"kind": "joint", "target": {"joints": FAR}, "speed": 0.1, "acceleration": 0.5}
    response = cell.runtime.api(
        "POST", "/motion/robots/robot/moves", json=request, headers=cell.headers()
    )
    assert response.status_code == 202, response.text
    wait_for(lambda: moving(cell), 10, what="the robot moving")
    status: dict[str, Any] = response.json()
    return status


def start_slow_program(cell: Cell, name: str) -> None:
    source = f"set_speed(10)\nmove_joint({FAR_DEGREES!r})\nprint('arrived')"
    saved = cell.runtime.api("PUT", f"/programs/{name}", json={"python": source})
    assert saved.status_code == 200, saved.text
    body = {"leases": {"robot": cell.token}, "robot": "robot"}
    started = cell.runtime.api("POST", f"/programs/{name}/run", json=body)
    assert started.status_code == 202, started.text
    wait_for(lambda: moving(cell), 10, what="the robot moving")
    time.sleep(0.3)


def run_failed(cell: Cell, name: str) -> dict[str, Any]:
    def ended() -> dict[str, Any] | None:
        status: dict[str, Any] = cell.runtime.api("GET", f"/programs/{name}/status").json()
        return None if status["state"] in ("starting", "running", "paused") else status

    status = wait_for(ended, 20, what="the run to end")
    assert status["state"] == "error", status
    assert status["error"]["message"]
    assert all(o["text"] != "arrived" for o in status["output"])
    return status


def test_a_killed_motion_service_halts_its_move_and_the_run_fails(ready: Cell) -> None:
    start_slow_program(ready, "through_motion")
    before = ready.robot.last_command_seq()
    killed = kill(ready, "motion")
    assert halted_after(ready, killed, before) < HALT_WITHIN
    assert_stays_still(ready)
    failed = run_failed(ready, "through_motion")
    print("run failed with:", failed["error"]["message"])


def test_a_killed_jog_service_halts_a_held_jog(ready: Cell) -> None:
    jog = JogClient(ready.runtime, token=ready.token)
    try:
        press = jog.press(kind="joint", axis=0, direction=1, speed=0.5)
        for _ in range(10):
            jog.send({"type": "heartbeat", "press": press})
            jog.drain(0.03)
        assert moving(ready)
        before = ready.robot.last_command_seq()
        killed = kill(ready, "jog")
        # The driver's own 200 ms command timeout would stop it too; the halt comes first.
        assert halted_after(ready, killed, before) < HALT_WITHIN
    finally:
        jog.close()
    assert_stays_still(ready)


def test_a_killed_device_manager_halts_a_program_and_the_run_fails(ready: Cell) -> None:
    start_slow_program(ready, "on_the_link")
    before = ready.robot.last_command_seq()
    killed = kill(ready, "device_manager")
    assert halted_after(ready, killed, before) < HALT_WITHIN
    assert_stays_still(ready)
    failed = run_failed(ready, "on_the_link")
    print("run failed with:", failed["error"]["message"])


def test_a_killed_device_manager_halts_a_move_and_the_move_fails(ready: Cell) -> None:
    move = start_slow_move(ready)
    before = ready.robot.last_command_seq()
    killed = kill(ready, "device_manager")
    assert halted_after(ready, killed, before) < HALT_WITHIN
    assert next(c["tag"] for c in ready.robot.commands(before) if c["type"] == "halt") in (
        "command stream closed",
        "session silent",
    )
    ended = wait_for(
        lambda: (
            ready.runtime.api("GET", f"/motion/moves/{move['id']}").json()
            if ready.runtime.api("GET", f"/motion/moves/{move['id']}").json()["state"]
            not in ("planning", "running")
            else None
        ),
        10,
        what="the move to end",
    )
    assert ended["state"] == "failed"
    assert ended["code"] in ("device_disconnected", "link_changed", "link_stale")
    assert_stays_still(ready)
    # The lease outlived the device manager: the holder keeps control, nobody else gets it.
    wait_for(lambda: healthy(ready), 30, what="the device manager back")
    kept = ready.runtime.api("POST", "/devices/robot/lease/check", headers=ready.headers())
    assert kept.status_code == 200, kept.text
    other = ready.runtime.api("POST", "/devices/robot/lease", json={"holder": "intruder"})
    assert other.status_code == 409 and other.json()["error"]["code"] == "lease_held"


def test_a_killed_program_service_halts_its_run_and_records_it_failed(ready: Cell) -> None:
    source = f"set_speed(10)\nmove_joint({FAR_DEGREES!r})"
    saved = ready.runtime.api("PUT", "/programs/slow", json={"python": source})
    assert saved.status_code == 200, saved.text
    # The run takes the robot's lease itself, as a run started from elsewhere does.
    ready.runtime.api("DELETE", "/devices/robot/lease", headers=ready.headers())
    started = ready.runtime.api("POST", "/programs/slow/run", json={"robot": "robot"})
    assert started.status_code == 202, started.text
    wait_for(lambda: moving(ready), 10, what="the robot moving")
    holder = ready.runtime.api("GET", "/devices/robot/lease").json()["holder"]
    assert holder == "program slow"
    time.sleep(0.3)
    service = int(ready.runtime.api("GET", "/health").json()["services"]["program"]["pid"])
    helpers = children(service)  # its program compiler, its run's worker
    assert helpers
    before = ready.robot.last_command_seq()
    killed = kill(ready, "program")
    assert halted_after(ready, killed, before) < HALT_WITHIN
    assert_stays_still(ready)
    # Nothing of it lingers: no orphan holds memory (or a robot) for ever.
    wait_for(lambda: not any(alive(pid) for pid in helpers), 5, what="its helpers gone")
    wait_for(lambda: healthy(ready), 30, what="the program service back")
    status = wait_for(
        lambda: (
            (s := ready.runtime.api("GET", "/programs/slow/status").json())["state"] == "error"
            and s
        ),
        10,
        what="the run recorded as failed",
    )
    assert status["error"]["code"] == "service_crashed"
    assert "stopped during this run" in status["error"]["message"]
    # Its lease was released at once, not left to lapse.
    wait_for(
        lambda: ready.runtime.api("GET", "/devices/robot/lease").json()["holder"] is None,
        3,
        what="the crashed run's lease released",
    )


KILLS = 50  # the count
MOTION = ("trajectory", "jog", "command_mode:trajectory", "command_mode:jog")


# A move is refused on a link whose states stopped for 200 ms (the product's rule). On this
# 2-core machine, under load, a state stream once stalled that long as a run began (its
# error: "robot is stale: stale: no state for 200 ms"), and the run ended before it moved.
# Such a run is started again once every service is up, and counted.
STALLED = ("link_stale", "device_disconnected")


def run_until_a_move_ends(
    cell: Cell, kill_no: int, again: list[int], not_before: float = 0.0
) -> None:
    """A run started, until one of its moves ends at `not_before` (monotonic) or later."""
    body = {"leases": {"robot": cell.token}, "robot": "robot"}
    asked = [0.0]

    def moving_or_ended() -> str | dict[str, Any] | None:
        if cell.robot.state()["flags"]["trajectory_running"]:
            return "moving"
        if time.monotonic() - asked[0] < 0.1:  # the run's status, not at every poll
            return None
        asked[0] = time.monotonic()
        status: dict[str, Any] = cell.runtime.api("GET", "/programs/to_and_fro/status").json()
        return status if status["state"] in ("error", "stopped", "finished") else None

    for _ in range(3):
        wait_for(lambda: healthy(cell), 30, what="every service up")
        started = cell.runtime.api("POST", "/programs/to_and_fro/run", json=body)
        assert started.status_code == 202, started.text
        found = wait_for(moving_or_ended, 10, 0.005, what=f"kill {kill_no}: a move or the end")
        if found == "moving":
            while True:  # the program moves to and fro: one move after another
                wait_for(lambda: not running(cell), 10, 0.005, what=f"kill {kill_no}: a move's end")
                if time.monotonic() >= not_before:
                    return
                wait_for(lambda: running(cell), 10, 0.005, what=f"kill {kill_no}: the next move")
        assert isinstance(found, dict)
        code = (found.get("error") or {}).get("code")
        assert code in STALLED, f"kill {kill_no}: the run ended before it moved: {found}"
        again.append(kill_no)
    raise AssertionError(f"kill {kill_no}: three runs ended on a stalled link before moving")


def running(cell: Cell) -> bool:
    return bool(cell.robot.state()["flags"]["trajectory_running"])


def halt_since(cell: Cell, seq: int) -> dict[str, Any]:
    halts = wait_for(
        lambda: [c for c in cell.robot.commands(seq) if c["type"] == "halt"], 5, what="a halt"
    )
    return halts[0]


def test_a_killed_program_service_never_has_its_next_move_run(ready: Cell) -> None:
    """Killed 0-400 ms after one of its moves ended, while the motion service plans the
    next: the driver's command log shows no motion command after the halt, 50 times over.
    (Once in 8 such kills, the next move ran for 0.75 s: it reached the robot after the
    halt, under a lease and a link that were still alive.)"""
    here = ready.robot.q()
    a = [round(math.degrees(v), 4) for v in here]
    b = [a[0] + 5.0, *a[1:]]
    source = f"set_speed(100)\nfor i in range(100000):\n    move_joint({a})\n    move_joint({b})"
    saved = ready.runtime.api("PUT", "/programs/to_and_fro", json={"python": source})
    assert saved.status_code == 200, saved.text
    rng = random.Random(31)
    delays = []
    again: list[int] = []
    up = 0.0
    for kill_no in range(KILLS):
        # Up for longer than HEALTHY_AFTER when killed, or the launcher waits longer before
        # each restart (0.05 s doubled to 10 s over a few quick kills: the test's lease
        # lapsed in one run): the kill follows the first move to end after that.
        run_until_a_move_ends(ready, kill_no, again, not_before=up + HEALTHY_AFTER + 0.1)
        delay = rng.uniform(0.0, 0.4)
        time.sleep(delay)
        delays.append(delay)
        before = ready.robot.last_command_seq()
        kill(ready, "program")
        halt = halt_since(ready, before)
        wait_for(lambda: healthy(ready), 30, what="the program service back")
        up = time.monotonic()
        ready.robot.wait_stopped()
        after = [c for c in ready.robot.commands(halt["seq"]) if c["type"] in MOTION]
        assert after == [], f"kill {kill_no} after {delay:.3f} s: {after} after {halt}"
    print(f"{KILLS} kills, {min(delays):.3f}-{max(delays):.3f} s after a move ended")
    print(f"runs started again after a stalled link, before kill: {again}")
