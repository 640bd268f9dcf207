"""Blockly programs through the program service against the simulated UR5: a pick-and-place
program saved through the API runs to completion with its output and block ids streaming;
pause, step, resume and stop behave, a stop during a long move halts the robot at once;
bad programs and targets are refused with the block named, and the robot stays put."""

from __future__ import annotations

import ast
import json
import math
import sqlite3
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest
from websockets.sync.client import connect

from openpendant.runtime.bench.harness.blocks import (
    block,
    ids_of,
    number,
    stack,
    text,
    var,
    waypoint,
    workspace,
)
from openpendant.runtime.bench.harness.jog import Cell
from openpendant.runtime.bench.harness.processes import STILL, Runtime, wait_for
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.sandbox.protocol import ISOLATION
from tests.support.programs import HOME, PICK_AND_PLACE_WAYPOINTS, PLACE, pick_and_place, teach

FAR = [2.5, -1.0, 1.2, -1.5, -1.57, 1.0]
FAR_DEGREES = [round(math.degrees(v), 6) for v in FAR]


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    runtime = Runtime(tmp_path_factory.mktemp("programs"))
    runtime.wait_ready()
    try:
        cell = Cell(runtime)
        teach(runtime, {**PICK_AND_PLACE_WAYPOINTS, "far": FAR, "home_pose": HOME})
        yield cell
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


@pytest.fixture
def ready(cell: Cell) -> Cell:
    cell.ready()
    if np.abs(cell.robot.q() - np.array(HOME)).max() > 1e-3:
        cell.place(HOME)
    return cell


def save(cell: Cell, name: str, ws: dict[str, Any]) -> str:
    response = cell.runtime.api("PUT", f"/programs/{name}", json={"workspace": ws})
    assert response.status_code == 200, response.text
    python: str = response.json()["python"]
    return python


def save_python(cell: Cell, name: str, source: str) -> None:
    response = cell.runtime.api("PUT", f"/programs/{name}", json={"python": source})
    assert response.status_code == 200, response.text


def run(cell: Cell, name: str, **options: Any) -> dict[str, Any]:
    body = {"leases": {"robot": cell.token}, **options}
    response = cell.runtime.api("POST", f"/programs/{name}/run", json=body)
    assert response.status_code == 202, response.text
    status: dict[str, Any] = response.json()
    return status


def status(cell: Cell, name: str, after: int = 0) -> dict[str, Any]:
    found: dict[str, Any] = cell.runtime.api(
        "GET", f"/programs/{name}/status", params={"after": after}
    ).json()
    return found


def watch(cell: Cell, name: str, until: tuple[str, ...], timeout: float = 60.0) -> dict[str, Any]:
    """Poll the status until one of `until`; returns the last status with every block seen."""
    seen: list[str] = []
    deadline = time.monotonic() + timeout
    while True:
        current = status(cell, name)
        if current["block"] and (not seen or seen[-1] != current["block"]):
            seen.append(current["block"])
        if current["state"] in until:
            current["seen"] = seen
            return current
        assert time.monotonic() < deadline, current
        time.sleep(0.02)


def test_a_pick_and_place_program_runs_to_completion(ready: Cell) -> None:
    ws, main = pick_and_place()
    python = save(ready, "pick_and_place", ws)
    assert "move_linear(waypoint('pick'))" in python
    assert "for spot in ['pick', 'place']:" in python.replace('"', "'")
    stored = ready.runtime.api("GET", "/programs/pick_and_place").json()
    assert stored["workspace"] == ws and stored["python"] == python

    before = ready.robot.last_command_seq()
    with ready.robot.faster():  # only where the moves end matters here
        started = run(ready, "pick_and_place")
        assert started["state"] in ("starting", "running")
        final = watch(ready, "pick_and_place", ("finished", "error", "stopped"))
    assert final["state"] == "finished", final
    # The worker had every limit this machine grants (all of them, as root), and the
    # program service said so in its log.
    assert final["isolation"] == list(ISOLATION)
    log = (ready.runtime.data_dir / "logs" / "program.log").read_text()
    assert "program workers run with every limit" in log
    outputs = [(o["text"], o["block"]) for o in final["output"]]
    printed = [t for t, _ in outputs]
    assert printed == ["done pick", "done place", "cycle complete"]
    # Every output line names the block it came from, and the highlight moved through the
    # program's blocks.
    block_ids = set(ids_of(main))
    assert all(b in block_ids for _, b in outputs)
    assert len(set(final["seen"])) >= 6
    assert set(final["seen"]) <= block_ids

    assert ready.robot.stopped()
    end = ready.robot.state()
    assert end["tool_open"] is True
    assert end["digital_outputs"][1] is True
    # 40 mm straight up from the place waypoint.
    place_tcp = ready.runtime.api(
        "POST", "/motion/robots/robot/plan", json={"kind": "joint", "target": {"joints": PLACE}}
    ).json()["tcp_path"][-1]
    assert np.linalg.norm(np.array(end["tcp_pose"]["position"]) - place_tcp - [0, 0, 0.04]) < 2e-3
    kinds = [c["type"] for c in ready.robot.commands(before)]
    assert kinds.count("tool:close") == 1 and kinds.count("tool:open") == 2
    assert kinds.index("tool:close") < len(kinds) - 1 - kinds[::-1].index("tool:open")


def counting_loop() -> tuple[dict[str, Any], list[str]]:
    steps = [
        block("text_print", TEXT=var("i")),
        block("time_wait", SECONDS=number(0.15)),
    ]
    loop = block(
        "controls_for",
        {"VAR": {"id": "i"}},
        FROM=number(1),
        TO=number(30),
        BY=number(1),
        DO=stack(*steps),
    )
    return workspace(loop, variables=("i",)), [loop["id"], *[s["id"] for s in steps]]


def test_pause_step_resume(ready: Cell) -> None:
    ws, ids = counting_loop()
    save(ready, "counting", ws)
    run(ready, "counting")
    wait_for(lambda: len(status(ready, "counting")["output"]) >= 2, 10)
    ready.runtime.api("POST", "/programs/counting/pause")
    paused = watch(ready, "counting", ("paused",), 5)
    assert paused["block"] in ids and paused["pause_reason"] == "pause"
    printed = len(paused["output"])
    time.sleep(0.5)
    assert len(status(ready, "counting")["output"]) == printed  # nothing runs while paused

    # Each step runs one block and pauses again at the next.
    blocks = [paused["block"]]
    for _ in range(4):
        ready.runtime.api("POST", "/programs/counting/step")

        def next_pause(previous: str = blocks[-1]) -> dict[str, Any] | None:
            current = status(ready, "counting")
            moved = current["state"] == "paused" and current["block"] != previous
            return current if moved else None

        blocks.append(wait_for(next_pause, 5, what="the step's pause")["block"])
    assert all(b in ids for b in blocks)
    assert len(set(blocks)) == 3  # the loop, the print and the wait, in turn
    assert len(status(ready, "counting")["output"]) in (printed + 1, printed + 2)

    ready.runtime.api("POST", "/programs/counting/resume")
    assert watch(ready, "counting", ("finished", "error"), 30)["state"] == "finished"
    assert [o["text"] for o in status(ready, "counting")["output"]] == [
        str(i) for i in range(1, 31)
    ]


def off_the_joint_line(rows: list[list[float]], start: np.ndarray, goal: np.ndarray) -> float:
    direction = (goal - start) / np.linalg.norm(goal - start)
    points = np.array(rows) - start
    along = points @ direction
    return float(np.max(np.linalg.norm(points - np.outer(along, direction), axis=1)))


def test_pause_stops_the_robot_on_its_path_and_resume_finishes_the_move(ready: Cell) -> None:
    """Pause during a move: the robot comes to a controlled stop on its path at once (not
    at the end of the move) and stays; resume continues the same move to its target."""
    save_python(ready, "pausing", f"set_speed(40)\nmove_joint({FAR_DEGREES!r})\nprint('there')")
    start = ready.robot.q()
    after = int(ready.robot.state()["seqno"])
    run(ready, "pausing")
    wait_for(lambda: np.abs(ready.robot.state()["joint_velocity"]).max() > 0.3, 10, what="moving")
    asked = time.monotonic()
    paused = ready.runtime.api("POST", "/programs/pausing/pause").json()
    assert paused["state"] == "paused"
    ready.robot.wait_stopped(2.0)
    stopped_after = time.monotonic() - asked
    held = ready.robot.q()
    time.sleep(0.5)
    assert np.abs(ready.robot.q() - held).max() < STILL  # paused means still
    assert np.abs(held - np.array(FAR)).max() > 0.3  # it did not finish the move first
    assert status(ready, "pausing")["state"] == "paused"
    assert stopped_after < 1.5, f"took {stopped_after:.2f} s to stop"
    ready.runtime.api("POST", "/programs/pausing/resume")
    finished = watch(ready, "pausing", ("finished", "error", "stopped"), 60)
    assert finished["state"] == "finished", finished
    assert [o["text"] for o in finished["output"]] == ["there"]
    assert np.abs(ready.robot.q() - np.array(FAR)).max() < 1e-4
    rows = ready.robot.setpoints(after)["position"]
    worst = off_the_joint_line(rows, start, np.array(FAR))
    assert worst < 1e-3, f"{worst:.2e} rad off the straight joint path"


def test_the_speed_override_slows_a_running_program_on_its_path(ready: Cell) -> None:
    save_python(ready, "override", f"set_speed(60)\nmove_joint({FAR_DEGREES!r})")
    start = ready.robot.q()
    after = int(ready.robot.state()["seqno"])
    run(ready, "override")
    wait_for(lambda: np.abs(ready.robot.state()["joint_velocity"]).max() > 0.1, 10, what="moving")
    time.sleep(0.4)  # at its cruising speed (manual mode: the TCP at 250 mm/s)
    full = np.abs(ready.robot.state()["joint_velocity"]).max()
    slower = ready.runtime.api("PUT", "/jog/robots/robot/speed", json={"ratio": 0.2})
    assert slower.status_code == 200, slower.text  # lowering needs no control
    time.sleep(1.0)
    slowed = np.abs(ready.robot.state()["joint_velocity"]).max()
    assert 0 < slowed < 0.35 * full
    faster = ready.runtime.api("PUT", "/jog/robots/robot/speed", json={"ratio": 1.0})
    assert faster.status_code == 409  # raising it does
    back = ready.runtime.api(
        "PUT", "/jog/robots/robot/speed", json={"ratio": 1.0}, headers=ready.headers()
    )
    assert back.status_code == 200, back.text
    assert watch(ready, "override", ("finished", "error", "stopped"), 60)["state"] == "finished"
    rows = ready.robot.setpoints(after)["position"]
    assert off_the_joint_line(rows, start, np.array(FAR)) < 1e-3


def test_a_breakpoint_pauses_before_its_block(ready: Cell) -> None:
    ws, ids = counting_loop()
    save(ready, "breaking", ws)
    run(ready, "breaking", breakpoints=[ids[2]])  # the wait
    paused = watch(ready, "breaking", ("paused",), 10)
    assert paused["block"] == ids[2] and paused["pause_reason"] == "breakpoint"
    assert [o["text"] for o in paused["output"]] == ["1"]
    ready.runtime.api("PUT", "/programs/breaking/breakpoints", json={"ids": []})
    ready.runtime.api("POST", "/programs/breaking/resume")
    assert watch(ready, "breaking", ("finished", "error"), 30)["state"] == "finished"


def test_stop_during_a_long_move_halts_the_robot(ready: Cell) -> None:
    ws = workspace(
        stack(
            block("robot_set_speed", SPEED=number(10)),
            block("robot_move_joint", TARGET=waypoint("far")),
            block("text_print", TEXT=text("never")),
        )
    )
    save(ready, "long_move", ws)
    run(ready, "long_move")
    wait_for(lambda: not ready.robot.stopped(), 10, what="the robot moving")
    time.sleep(0.3)
    before = ready.robot.last_command_seq()
    sent = time.time()
    # The webui stamps when the stop reached it; a client's own stamp is replaced.
    stopped = ready.runtime.api(
        "POST", "/programs/long_move/stop", headers={"X-Request-Start": "1"}
    ).json()
    assert sent <= stopped["stop_request_start"] <= stopped["stop_received"] <= time.time()
    assert stopped["state"] == "stopped" and stopped["robots"] == ["robot"]
    commands = [c["type"] for c in ready.robot.commands(before)]
    assert "halt" in commands
    ready.robot.wait_stopped(2.0)
    q = ready.robot.q()
    time.sleep(0.5)
    assert np.abs(ready.robot.q() - q).max() < STILL  # nothing resumes after the stop
    assert np.abs(q - np.array(FAR)).max() > 0.1
    assert all(o["text"] != "never" for o in status(ready, "long_move")["output"])


def test_a_stop_is_not_held_up_by_the_heaviest_save(ready: Cell) -> None:
    """The largest program the sandbox policy takes compiles for seconds; a stop sent while
    it compiles halts the robot long before that save is done (issue 15: it waited for it,
    and answered a moment before the save did)."""
    save_python(ready, "moving", f"set_speed(10)\nmove_joint({FAR_DEGREES!r})")
    run(ready, "moving")
    wait_for(lambda: not ready.robot.stopped(), 10, what="the robot moving")
    heavy = "a = [1, 2, 3, 4, 5, 6, 7, 8, 9]\n" * 62_000  # just under 2,000,000 characters
    saved: list[tuple[int, float]] = []

    def save_heavy() -> None:
        response = ready.runtime.api("PUT", "/programs/heavy", json={"python": heavy}, timeout=60)
        saved.append((response.status_code, time.monotonic()))

    saving = threading.Thread(target=save_heavy)
    saving.start()
    time.sleep(0.5)  # its 2 MB reach the program service, which then compiles for seconds
    before = ready.robot.last_command_seq()
    sent = time.monotonic()
    stopped = ready.runtime.api("POST", "/programs/moving/stop").json()
    answered = time.monotonic()  # the answer comes once the halt is sent
    assert stopped["state"] == "stopped"
    assert "halt" in [c["type"] for c in ready.robot.commands(before)]
    ready.robot.wait_stopped(2.0)
    saving.join(60)
    status, save_done = saved[0]
    assert status in (200, 504)  # saved, or given up on by the gateway on a loaded host
    # Relative, not a timing goal: both run on the same host, and the compile is seconds.
    assert answered - sent < (save_done - sent) / 2, "the stop waited for the compile"


def test_the_pendants_stop_stops_every_running_program(ready: Cell) -> None:
    """The safety bar's STOP: POST /programs/_stop stops whatever runs, and halts it."""
    save_python(ready, "stopped_by_stop", f"set_speed(10)\nmove_joint({FAR_DEGREES!r})")
    run(ready, "stopped_by_stop")
    wait_for(lambda: not ready.robot.stopped(), 10, what="the robot moving")
    before = ready.robot.last_command_seq()
    stopped = ready.runtime.api("POST", "/programs/_stop").json()
    assert stopped["stopped"] == ["stopped_by_stop"]
    assert status(ready, "stopped_by_stop")["state"] == "stopped"
    assert "halt" in [c["type"] for c in ready.robot.commands(before)]
    ready.robot.wait_stopped(2.0)
    assert ready.runtime.api("POST", "/programs/_stop").json()["stopped"] == []


def test_stop_over_the_program_socket_halts_the_robot(ready: Cell) -> None:
    save_python(ready, "socket_stop", f"set_speed(10)\nmove_joint({FAR_DEGREES!r})")
    url = ready.runtime.url.replace("http", "ws") + "/api/programs/_ws"
    with connect(url, additional_headers=ready.runtime.auth("viewer")) as socket:
        socket.send(json.dumps({"type": "stop"}))
        answers = iter(lambda: json.loads(socket.recv(timeout=5)), None)
        refusal = next(a for a in answers if a.get("type") == "error")  # after the statuses
        assert refusal["error"]["code"] == "bad_message"
        run(ready, "socket_stop")
        wait_for(lambda: not ready.robot.stopped(), 10, what="the robot moving")
        before = ready.robot.last_command_seq()
        socket.send(json.dumps({"type": "stop", "program": "socket_stop"}))
        wait_for(lambda: status(ready, "socket_stop")["state"] == "stopped", 5, what="stopped")
    assert "halt" in [c["type"] for c in ready.robot.commands(before)]
    ready.robot.wait_stopped(2.0)
    q = ready.robot.q()
    time.sleep(0.3)
    assert np.abs(ready.robot.q() - q).max() < STILL


def long_line() -> tuple[list[float], str]:
    """Joints at one end of a straight 0.8 m line in front of the robot, tool down, and a
    linear move to its other end: planning it (a joint solution every mm, checked, then
    timed) takes long enough to stop the run on the way (planning around the posts has
    become too quick for that)."""
    kinematics = Kinematics(load_robot_info("ur5"))
    reference = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    down = kinematics.tcp(reference).rotation.copy()
    start = pin.SE3(down, np.array([-0.5, -0.4, 0.25]))
    joints = kinematics.inverse(start, reference)
    roll, pitch, yaw = np.degrees(pin.rpy.matrixToRpy(down))
    return [float(v) for v in joints], f"pose(-500, 400, 250, {roll:.6f}, {pitch:.6f}, {yaw:.6f})"


def test_stop_while_a_move_is_planned_means_it_never_starts(ready: Cell) -> None:
    start, end = long_line()
    ready.place(start)
    save_python(ready, "long_line", f"print('moving')\nmove_linear({end})\nprint('never')")
    before = ready.robot.last_command_seq()
    run(ready, "long_line")
    wait_for(
        lambda: any(o["text"] == "moving" for o in status(ready, "long_line")["output"]),
        10,
        interval=0.01,
        what="the move to be asked for",
    )
    assert "trajectory" not in [c["type"] for c in ready.robot.commands(before)]
    stopped = ready.runtime.api("POST", "/programs/long_line/stop").json()
    assert stopped["state"] == "stopped", (stopped["error"], stopped["output"])
    # The planner holds the world until it is done: a preview after it means it ended.
    preview = {"kind": "joint", "target": {"joints": start}}
    ready.runtime.api("POST", "/motion/robots/robot/plan", json=preview).raise_for_status()
    time.sleep(0.3)
    assert "trajectory" not in [c["type"] for c in ready.robot.commands(before)]
    assert np.allclose(ready.robot.q(), start, atol=1e-6)
    assert all(o["text"] != "never" for o in status(ready, "long_line")["output"])


BAD_TARGETS = {
    "joint limit": ("move_joint([999, 0, 0, 0, 0, 0])", "limit"),
    "NaN": ("move_joint([float('nan'), 0, 0, 0, 0, 0])", "finite"),
    "unreachable pose": ("move_joint(pose(5000, 0, 0, 180, 0, 0))", "reach"),
    "unknown waypoint": ("move_joint(waypoint('nowhere'))", "nowhere"),
    "unknown robot": ("use_robot('ghost')", "ghost"),
}


@pytest.mark.parametrize(("call", "expected"), BAD_TARGETS.values(), ids=BAD_TARGETS.keys())
def test_bad_targets_are_refused_at_their_block_and_nothing_moves(
    ready: Cell, call: str, expected: str
) -> None:
    source = f"at_block('first')\nprint('start')\nat_block('bad')\n{call}\nprint('after')\n"
    response = ready.runtime.api("PUT", "/programs/bad_target", json={"python": source})
    assert response.status_code == 200, response.text
    q = ready.robot.q()
    before = ready.robot.last_command_seq()
    run(ready, "bad_target")
    final = watch(ready, "bad_target", ("finished", "error", "stopped"), 30)
    assert final["state"] == "error"
    assert final["error"]["block"] == "bad" and final["error"]["line"] == 4
    assert expected in final["error"]["message"].lower()
    printed = [o["text"] for o in final["output"] if o["stream"] == "out"]
    assert printed == ["start"]
    moves = [c for c in ready.robot.commands(before) if c["type"] in ("trajectory",)]
    assert moves == []
    assert np.abs(ready.robot.q() - q).max() < STILL
    assert ready.runtime.api("GET", "/programs/bad_target/status").status_code == 200


def test_attacks_through_the_service_leave_the_runtime_healthy(ready: Cell) -> None:
    attacks = [
        "x = ().__class__",
        "import os",
    ]
    for source in attacks:
        response = ready.runtime.api("PUT", "/programs/attack", json={"python": source})
        assert response.status_code == 422, response.text
        assert response.json()["error"]["code"] == "invalid_program"
    response = ready.runtime.api("PUT", "/programs/attack", json={"python": "while True:\n  pass"})
    assert response.status_code == 200
    run(ready, "attack")
    time.sleep(1.0)
    assert status(ready, "attack")["state"] == "running"
    health = ready.runtime.api("GET", "/health")
    assert health.status_code == 200
    assert ready.runtime.api("POST", "/programs/attack/stop").json()["state"] == "stopped"


def test_malformed_workspaces_are_refused_and_nothing_is_saved(ready: Cell) -> None:
    cases = [
        (
            {"workspace": {"blocks": {"blocks": [{"type": "os_system", "id": "x"}]}}},
            "unknown block type",
        ),
        (
            {"workspace": {"blocks": {"blocks": [{"type": "logic_boolean", "id": "x"}]}}},
            "lacks its BOOL",
        ),
        ({"workspace": {"blocks": "nope"}}, "must be an object"),
        ({"nothing": 1}, "send"),
    ]
    for body, expected in cases:
        for method, path in (("PUT", "/programs/malformed"), ("POST", "/programs/_generate")):
            response = ready.runtime.api(method, path, json=body)
            assert response.status_code == 422, response.text
            assert expected in response.json()["error"]["message"]
    deep = '{"workspace": ' + "[" * 200_000 + "]" * 200_000 + "}"
    response = ready.runtime.api(
        "PUT", "/programs/malformed", content=deep, headers={"content-type": "application/json"}
    )
    assert response.status_code == 422, response.text
    assert ready.runtime.api("GET", "/programs/malformed").status_code == 404
    assert ready.runtime.api("POST", "/programs/malformed/run", json={}).status_code == 404


def test_the_preview_gives_the_python_saving_would_and_keeps_nothing(ready: Cell) -> None:
    ws, _ = pick_and_place()
    preview = ready.runtime.api("POST", "/programs/_generate", json={"workspace": ws})
    assert preview.status_code == 200, preview.text
    assert ready.runtime.api("GET", "/programs/previewed").status_code == 404
    assert preview.json()["python"] == save(ready, "previewed", ws)
    assert preview.json()["blocks"] > 20
    python_only = ready.runtime.api("POST", "/programs/_generate", json={"python": "x = 1"})
    assert python_only.status_code == 422


def test_a_program_needs_the_robots_control_lease(ready: Cell) -> None:
    save(ready, "no_lease", workspace(block("robot_move_joint", TARGET=waypoint("above_pick"))))
    response = ready.runtime.api("POST", "/programs/no_lease/run", json={})
    assert response.status_code == 202
    final = watch(ready, "no_lease", ("finished", "error"), 20)
    assert final["state"] == "error"
    assert final["error"]["code"] == "lease_held" and "tests" in final["error"]["message"]
    assert ready.robot.stopped()


def test_programs_are_listed_renamed_duplicated_and_deleted(ready: Cell) -> None:
    save(ready, "original", workspace(block("text_print", TEXT=text("hi"))))
    copy = ready.runtime.api("POST", "/programs/original/duplicate", json={"to": "copy"})
    assert copy.status_code == 201
    renamed = ready.runtime.api("POST", "/programs/copy/rename", json={"to": "renamed"})
    assert renamed.json()["name"] == "renamed"
    names = {p["name"] for p in ready.runtime.api("GET", "/programs").json()}
    assert {"original", "renamed"} <= names and "copy" not in names
    assert ready.runtime.api("DELETE", "/programs/renamed").status_code == 204
    assert ready.runtime.api("GET", "/programs/renamed").status_code == 404
    history = ready.runtime.api("GET", "/variables/program.renamed/history").json()
    assert history[0]["deleted"] is True  # deleted, but its history keeps it


def test_a_program_goes_out_as_a_file_and_comes_back_to_run_as_it_was(ready: Cell) -> None:
    """Export and import for version control: the file holds the blocks and the Python
    generated from them; an imported file is checked as a save is, and what runs is the
    Python generated here, never the file's."""
    api = ready.runtime.api
    python = save(ready, "to_file", workspace(block("text_print", TEXT=text("from a file"))))
    exported = api("GET", "/programs/to_file/file")
    assert exported.status_code == 200, exported.text
    disposition = exported.headers["content-disposition"]
    assert disposition == 'attachment; filename="to_file.openpendant.json"'
    document = exported.json()
    assert document["format"] == "openpendant-program" and document["source"] == "blocks"
    assert "\n".join(document["python"]) == python
    assert document["workspace"] == api("GET", "/programs/to_file").json()["workspace"]
    assert exported.text.count("\n") > len(document["python"])  # a line a line: diffs well
    # A long stack of blocks (nested a level a block) grows its file in proportion.
    long = workspace(stack(*(block("text_print", TEXT=text(f"line {i}")) for i in range(400))))
    save(ready, "long_stack", long)
    long_file = api("GET", "/programs/long_stack/file")
    assert len(long_file.content) < 3 * len(json.dumps(long)), len(long_file.content)

    as_json = {"content-type": "application/json"}
    imported = api("PUT", "/programs/from_file/file", content=exported.content, headers=as_json)
    assert imported.status_code == 200, imported.text
    assert imported.json()["generated_as_in_file"] is True
    assert api("GET", "/programs/from_file").json()["python"] == python
    ran = api("POST", "/programs/from_file/run", json={})
    assert ran.status_code == 202, ran.text
    finished = watch(ready, "from_file", ("finished", "error", "stopped"), 30)
    assert [o["text"] for o in finished["output"]] == ["from a file"], finished

    # A file whose Python was edited by hand: the blocks are what is kept and run.
    edited = {**document, "python": ["import os", "os.system('reboot')"]}
    again = api("PUT", "/programs/from_file/file", json=edited)
    assert again.status_code == 200 and again.json()["generated_as_in_file"] is False
    assert again.json()["version"] == imported.json()["version"] + 1
    assert api("GET", "/programs/from_file").json()["python"] == python
    history = api("GET", "/variables/program.from_file/history").json()
    assert len(history) >= 2  # the replaced version is kept

    save_python(ready, "by_hand", "print('typed')\n")
    typed = api("GET", "/programs/by_hand/file").json()
    assert typed["source"] == "python" and typed["workspace"] is None
    copied = api("PUT", "/programs/by_hand_too/file", json=typed)
    assert copied.status_code == 200 and copied.json()["generated_as_in_file"] is None
    assert api("GET", "/programs/by_hand_too").json()["python"] == "print('typed')\n"

    # Bad files: a clear error, and nothing saved.
    unknown = workspace(block("no_such_block"))
    bad = {
        "not json": b"{",
        "no format": json.dumps({"source": "python", "python": ["x = 1"]}).encode(),
        "a wrong field": json.dumps({**typed, "python": "x = 1"}).encode(),
        "no blocks": json.dumps({**document, "workspace": None}).encode(),
        "an unknown block": json.dumps({**document, "workspace": unknown}).encode(),
        "refused python": json.dumps({**typed, "python": ["import os"]}).encode(),
    }
    for why, body in bad.items():
        refused = api("PUT", "/programs/never/file", content=body, headers=as_json)
        assert refused.status_code == 422, (why, refused.text)
        assert refused.json()["error"]["message"], why
        assert api("GET", "/programs/never").status_code == 404, why
    assert api("GET", "/programs/no_such/file").status_code == 404


def test_a_program_with_empty_inputs_or_loose_blocks_is_saved_but_does_not_run(
    ready: Cell,
) -> None:
    empty_if = block("controls_if", None, DO0=block("robot_move_joint", TARGET=waypoint("far")))
    stray = block("robot_move_joint", TARGET=waypoint("far"))
    stray["y"] = 400
    ws = workspace(empty_if, stray)
    saved = ready.runtime.api("PUT", "/programs/unfinished", json={"workspace": ws})
    assert saved.status_code == 200, saved.text  # nothing that was built is lost
    problems = {p["block"]: p["message"] for p in saved.json()["problems"]}
    assert set(problems) == {empty_if["id"], stray["id"]}
    preview = ready.runtime.api("POST", "/programs/_generate", json={"workspace": ws}).json()
    assert {p["block"] for p in preview["problems"]} == set(problems)
    before = ready.robot.last_command_seq()
    refused = ready.runtime.api(
        "POST", "/programs/unfinished/run", json={"leases": {"robot": ready.token}}
    )
    assert refused.status_code == 409
    error = refused.json()["error"]
    assert error["code"] == "program_has_problems"
    assert "the condition is empty" in error["message"]
    assert {p["block"] for p in error["details"]["problems"]} == set(problems)
    assert ready.robot.commands(before) == []


def run_to_end(cell: Cell, name: str, source: str) -> dict[str, Any]:
    save_python(cell, name, source)
    response = cell.runtime.api("POST", f"/programs/{name}/run", json={})
    assert response.status_code == 202, response.text
    return watch(cell, name, ("finished", "error", "stopped"), 30)


def test_a_program_reads_where_the_robot_is(ready: Cell) -> None:
    """joint_positions() and tcp_pose() read the robot's newest state (from the program
    service's own link to it, watched from the first read on): what the driver reports."""
    source = (
        "q = joint_positions()\n"
        "print(q)\n"
        "p = tcp_pose()\n"
        "print([pose_get(p, c) for c in ('x', 'y', 'z')])\n"
    )
    finished = run_to_end(ready, "where", source)
    assert finished["state"] == "finished", finished
    joints, position = (o["text"] for o in finished["output"])
    assert np.allclose(np.radians(ast.literal_eval(joints)), ready.robot.q(), atol=1e-6)
    tcp = np.array(ready.robot.state()["tcp_pose"]["position"]) * 1000.0
    assert np.allclose(ast.literal_eval(position), tcp, atol=1e-3)


def test_a_program_cannot_fill_the_store(ready: Cell) -> None:
    """Issue 15: 30 stores of big values grew the database by 115 MB."""
    filled = run_to_end(
        ready,
        "filler",
        "for i in range(40):\n    store('blob' + str(i), 'x' * 60000)\n    print(i)\n",
    )
    assert filled["state"] == "error"
    assert filled["error"]["code"] == "storage_full", filled["error"]
    kept = ready.runtime.api("GET", "/variables", params={"tag": "stored-by:filler"}).json()
    assert 10 <= len(kept) <= 18  # a mebibyte of them, no more
    assert sum(len(v["value"]) for v in kept) <= 1024 * 1024
    big = run_to_end(ready, "big_value", "store('blob', 'x' * 70000)\n")
    assert big["error"]["code"] == "too_large"


def in_use(database: Path) -> int:
    """The bytes of a SQLite database's pages in use, its WAL's newest included."""
    db = sqlite3.connect(f"file:{database}?mode=ro", uri=True)
    try:
        pages = db.execute("PRAGMA page_count").fetchone()[0]
        free = db.execute("PRAGMA freelist_count").fetchone()[0]
        return int((pages - free) * db.execute("PRAGMA page_size").fetchone()[0])
    finally:
        db.close()


REWRITER = """
for round in range(21):
    for i in range(6):
        at_block('big')
        store('kept' + str(i), 'y' * 60000)
        at_block('empty')
        store('kept' + str(i), '')
        print(round, i)
"""


def test_a_program_rewriting_big_values_is_stopped_at_its_budget_with_the_history_counted(
    ready: Cell,
) -> None:
    """Issue 32: 30 variables written 21 times with 60 KB and emptied grew the database from
    0.1 to 37.8 MB with no error: the budget counted current values only, while the store
    keeps 20 versions of each."""
    database = ready.runtime.data_dir / "variables.sqlite"
    before = in_use(database)
    ended = run_to_end(ready, "rewriter", REWRITER)
    assert ended["state"] == "error", "the loop ran to its end"
    error = ended["error"]
    assert error["code"] == "storage_full", error
    assert error["block"] == "big"
    assert "the earlier ones the history keeps included" in error["message"]
    assert "a program may keep 1048576" in error["message"]
    written = [o["text"] for o in ended["output"] if o["stream"] == "out"]
    assert 15 <= len(written) <= 17  # a mebibyte of 60 KB versions, no more
    kept = ready.runtime.api("GET", "/variables", params={"tag": "stored-by:rewriter"}).json()
    assert sorted(v["name"] for v in kept) == [f"kept{i}" for i in range(6)]
    assert all(v["value"] == "" for v in kept)  # every current value empty: all is history
    versions = [
        entry
        for v in kept
        for entry in ready.runtime.api("GET", f"/variables/{v['name']}/history").json()
    ]
    assert sum(len(e["value"]) for e in versions) <= 1024 * 1024
    # The store's size: what the program left and a few pages of SQLite's own.
    assert in_use(database) - before <= 1024 * 1024 + 128 * 1024


def test_a_program_names_only_variables_and_never_the_users_own(ready: Cell) -> None:
    save_python(ready, "victim", "print('mine')\n")
    for source, code in (
        ("print(stored('x/../_export'))", "invalid_name"),  # was: the whole store, exported
        ("print(stored('a\\nb'))", "invalid_name"),
        ("store('program.victim', 1)", "reserved_name"),
        ("store('far', [0, 0, 0, 0, 0, 0])", "reserved_name"),  # a taught waypoint
    ):
        ended = run_to_end(ready, "namer", source)
        assert ended["state"] == "error", source
        assert ended["error"]["code"] == code, (source, ended["error"])
    assert ready.runtime.api("GET", "/programs/victim").json()["python"] == "print('mine')\n"
    assert ready.runtime.api("GET", "/variables/far").json()["type"] == "joint_waypoint"


# The runtime's namespaces and a plugin's (the core's blocks register as the plugin "blocks").
RESERVED = ("frames.", "calibration.", "tools.", "detectors.", "program.", "vision.", "devices.")


@pytest.mark.parametrize("prefix", [*RESERVED, "blocks."])
def test_a_program_cannot_store_under_a_reserved_namespace(ready: Cell, prefix: str) -> None:
    """Issue 32: a program's store('frames.robot', …) succeeded and broke every move."""
    name = f"{prefix}probe"
    mine = {"position": [0.1, 0.2, 0.3], "orientation": [0.0, 0.0, 0.0, 1.0]}
    saved = ready.runtime.api(
        "PUT", f"/variables/{name}", role="programmer", json={"type": "pose", "value": mine}
    )
    assert saved.status_code == 200, saved.text
    try:
        source = f"at_block('store')\nstore({name!r}, pose(500, 0, 0))\n"
        ended = run_to_end(ready, "reserver", source)
        assert ended["state"] == "error"
        error = ended["error"]
        assert (error["code"], error["block"]) == ("reserved_name", "store"), error
        assert error["message"].startswith(f"{name} is reserved: names under {prefix} are ")
        assert "a program may read but not change" in error["message"]
        assert "changes them in the" in error["message"]
        after = ready.runtime.api("GET", f"/variables/{name}").json()
        assert (after["value"], after["version"]) == (mine, saved.json()["version"])
    finally:
        ready.runtime.api("DELETE", f"/variables/{name}")


def test_an_operators_program_cannot_break_motion_through_a_robots_frame(ready: Cell) -> None:
    """Issue 32: after an operator-run store('frames.robot', pose(500, 0, 0)) every plan was
    refused ("should be a frame, not a pose") and a programmer's save of the frame got 409."""
    assert ready.runtime.api("GET", "/variables/frames.robot").status_code == 404
    save_python(ready, "reframer", "at_block('store')\nstore('frames.robot', pose(500, 0, 0))\n")
    started = ready.runtime.api("POST", "/programs/reframer/run", role="operator", json={})
    assert started.status_code == 202, started.text
    ended = watch(ready, "reframer", ("finished", "error", "stopped"), 30)
    assert ended["state"] == "error", "the program stored a robot's frame"
    assert ended["error"]["code"] == "reserved_name", ended["error"]
    assert "a programmer changes them in the Scene panel" in ended["error"]["message"]
    assert ready.runtime.api("GET", "/variables/frames.robot").status_code == 404
    plan = ready.runtime.api(
        "POST", "/motion/robots/robot/plan", json={"kind": "joint", "target": {"joints": PLACE}}
    )
    assert plan.status_code == 200, plan.text
    identity = {"pose": {"position": [0, 0, 0], "orientation": [0, 0, 0, 1]}, "parent": "world"}
    try:
        frame = ready.runtime.api(
            "PUT",
            "/variables/frames.robot",
            role="programmer",
            json={"type": "frame", "value": identity},
        )
        assert frame.status_code == 200, frame.text
    finally:
        ready.runtime.api("DELETE", "/variables/frames.robot")


def test_program_names_with_paths_or_control_characters_are_refused(ready: Cell) -> None:
    for raw in ("..%2f..%2fvariables%2f_export", "a%0a", "%E2%80%AEevil", "a.b"):
        response = httpx.put(
            f"{ready.runtime.url}/api/programs/{raw}",
            json={"python": "x = 1"},
            headers=ready.runtime.auth("programmer"),
            timeout=10,
        )
        assert response.status_code in (400, 422), raw
        assert response.json()["error"]["code"] in ("bad_path", "invalid_name"), raw
    assert "_export" not in [p["name"] for p in ready.runtime.api("GET", "/programs").json()]


def test_only_so_many_programs_run_at_once(ready: Cell) -> None:
    """One per robot (here one) and three that command no robot: the fifth is refused."""
    save_python(ready, "waiting", "wait(60)\n")
    names = [f"waiting{i}" for i in range(5)]
    for name in names:
        ready.runtime.api("POST", "/programs/waiting/duplicate", json={"to": name})
    try:
        for name in names[:4]:
            response = ready.runtime.api("POST", f"/programs/{name}/run", json={})
            assert response.status_code == 202, response.text
        refused = ready.runtime.api("POST", f"/programs/{names[4]}/run", json={})
        assert refused.status_code == 409
        assert refused.json()["error"]["code"] == "too_many_runs"
        ready.runtime.api("POST", f"/programs/{names[0]}/stop")
        started = ready.runtime.api("POST", f"/programs/{names[4]}/run", json={})
        assert started.status_code == 202, started.text
    finally:
        ready.runtime.api("POST", "/programs/_stop")
