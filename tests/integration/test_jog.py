"""Jogging the simulated robot through the runtime, as the jog panel does: directions in the
base and tool frames, limits, singularities, incremental steps, the manual-mode TCP speed cap,
and the deadman."""

from __future__ import annotations

import json
import math
import re
import struct
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import (
    STILL,
    Runtime,
    SpaceMouseProc,
    child_env,
    wait_for,
)
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.support.posts import LEFT, RIGHT, clear_posts, put_posts

INFO = load_robot_info("ur5")
KINEMATICS = Kinematics(INFO)


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    # These tests are about motion, not the deadman (see test_deadman.py, at the default
    # 100 ms). On a loaded 2-core VM the hypervisor can stall a process for a few hundred
    # ms, which rightly halts a jog; a wider window keeps that out of these results.
    home = tmp_path_factory.mktemp("jog")
    runtime = Runtime(home, env=child_env(home, OPENPENDANT_DEADMAN_SECONDS="0.5"))
    runtime.wait_ready()
    try:
        yield Cell(runtime)
    finally:
        runtime.stop()
    assert runtime.service_errors() == []


@pytest.fixture
def jog(cell: Cell) -> Iterator[JogClient]:
    cell.ready()
    cell.place(INFO.home)
    client = JogClient(cell.runtime, token=cell.token)
    yield client
    client.close()


def tcp(q: np.ndarray[Any, Any]) -> pin.SE3:
    return KINEMATICS.tcp(q)


def tcp_speeds(samples: dict[str, Any]) -> np.ndarray[Any, Any]:
    positions = np.array([tcp(np.array(q)).translation for q in samples["position"]])
    speeds: np.ndarray[Any, Any] = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    return speeds / float(samples["cycle"])


@pytest.mark.parametrize(("axis", "direction"), [("x", 1), ("y", -1), ("z", 1)])
def test_base_frame_translation_moves_along_the_axis(
    cell: Cell, jog: JogClient, axis: str, direction: int
) -> None:
    before = tcp(cell.robot.q())
    jog.hold(0.5, kind="cartesian", axis=axis, direction=direction, frame="base", speed=0.4)
    cell.robot.wait_stopped()
    after = tcp(cell.robot.q())
    moved = after.translation - before.translation
    index = "xyz".index(axis)
    assert direction * moved[index] > 0.005  # how far depends on the host's scheduling
    assert np.abs(np.delete(moved, index)).max() < 1e-3  # straight along the axis
    assert np.linalg.norm(pin.log3(before.rotation.T @ after.rotation)) < 1e-3


@pytest.mark.parametrize(("axis", "frame"), [("x", "base"), ("y", "base"), ("z", "tool")])
def test_a_cartesian_jog_at_full_speed_keeps_its_line(
    cell: Cell, jog: JogClient, axis: str, frame: str
) -> None:
    """Speeding up to 250 mm/s, running and stopping when let go (issue 31): the TCP stays
    on its line all along, not only where it ends, measured on the simulator's setpoints
    (the joints' velocities change in step, and the line is steered back to)."""
    start = tcp(cell.robot.q())
    first = cell.robot.state()["seqno"]
    jog.hold(0.8, kind="cartesian", axis=axis, direction=1, frame=frame, speed=1.0)
    cell.robot.wait_stopped()
    samples = cell.robot.setpoints(first)
    index = "xyz".index(axis)
    along = start.rotation[:, index] if frame == "tool" else np.eye(3)[index]
    moved = np.array([tcp(np.array(q)).translation for q in samples["position"]])
    moved -= start.translation
    off = np.linalg.norm(moved - np.outer(moved @ along, along), axis=1)
    assert float((moved @ along)[-1]) > 0.05
    assert off.max() < 1e-3, f"{off.max() * 1000:.3f} mm off the line"  # 0.2-0.35 mm seen


def test_tool_frame_translation_follows_the_tool_axis(cell: Cell, jog: JogClient) -> None:
    before = tcp(cell.robot.q())
    jog.hold(0.5, kind="cartesian", axis="z", direction=1, frame="tool", speed=0.4)
    cell.robot.wait_stopped()
    moved = tcp(cell.robot.q()).translation - before.translation
    tool_z = before.rotation[:, 2]
    assert float(moved @ tool_z) > 0.005
    assert np.linalg.norm(moved - (moved @ tool_z) * tool_z) < 1e-3


def test_rotation_turns_about_the_tcp(cell: Cell, jog: JogClient) -> None:
    before = tcp(cell.robot.q())
    jog.hold(0.5, kind="cartesian", axis="rz", direction=1, frame="base", speed=0.5)
    cell.robot.wait_stopped()
    after = tcp(cell.robot.q())
    rotation = pin.log3(after.rotation @ before.rotation.T)
    assert rotation[2] > math.radians(1)  # about base z
    assert np.abs(rotation[:2]).max() < 1e-3
    assert np.linalg.norm(after.translation - before.translation) < 1e-3  # TCP stays put


def test_freedrive_lets_a_hand_move_the_arm_only_while_held(cell: Cell, jog: JogClient) -> None:
    """Freedrive held: a hand on the wrist moves it. Let go of the button: the arm holds
    where the hand left it, though the hand still pushes, and nothing resumes."""
    cell.robot.http.put("/sim/hand", json={"velocity": [0, 0, 0, 0.3, 0, 0]})
    try:
        start = cell.robot.q()
        jog.drain(0.2)  # the hand pushes, nothing holds the arm free: it stays
        assert np.allclose(cell.robot.q(), start, atol=1e-9)
        press = jog.press(type="freedrive")
        with jog.held(press):
            assert jog.status(press, ("moving", "refused"))["state"] == "moving"
            wait_for(lambda: cell.robot.q()[3] - start[3] > 0.05, 5, what="the wrist moved")
            assert cell.robot.state()["command_mode"] == "freedrive"
        jog.send({"type": "release", "press": press})
        assert jog.status(press, ("stopped", "halted"))["state"] == "stopped"
        cell.robot.wait_stopped()
        moved = cell.robot.q() - start
        assert moved[3] > 0.05 and np.allclose(np.delete(moved, 3), 0.0, atol=1e-9)
        held = cell.robot.q()
        jog.drain(0.2)
        assert np.allclose(cell.robot.q(), held, atol=1e-9)
        assert cell.robot.state()["command_mode"] == "halt"
    finally:
        cell.robot.http.put("/sim/hand", json={"velocity": [0.0] * 6})


@pytest.mark.parametrize(("joint", "direction"), [(0, 1), (3, -1)])
def test_joint_jog_moves_one_joint(cell: Cell, jog: JogClient, joint: int, direction: int) -> None:
    before = cell.robot.q()
    jog.hold(0.4, kind="joint", axis=joint, direction=direction, speed=0.5)
    cell.robot.wait_stopped()
    moved = cell.robot.q() - before
    assert direction * moved[joint] > math.radians(0.5)
    assert np.abs(np.delete(moved, joint)).max() < 1e-9


def test_a_joint_jog_stops_at_the_joint_limit(cell: Cell, jog: JogClient) -> None:
    # The wrist's last joint: near its limit without folding the arm onto itself.
    near = np.array(INFO.home)
    near[5] = INFO.joints[5].upper - math.radians(8)
    cell.place(near)
    first = cell.robot.state()["seqno"]
    jog.hold(1.5, kind="joint", axis=5, direction=1, speed=1.0)
    cell.robot.wait_stopped()
    samples = cell.robot.setpoints(first)
    wrist = np.array(samples["position"])[:, 5]
    assert wrist.max() <= INFO.joints[5].upper
    assert wrist.max() > INFO.joints[5].upper - math.radians(1)
    assert not cell.robot.state()["flags"]["error"]


def test_near_a_singularity_joint_speeds_stay_bounded(cell: Cell, jog: JogClient) -> None:
    singular = np.array(INFO.home)
    singular[4] = math.radians(0.5)  # wrist 2 almost straight: wrist singularity
    cell.place(singular)
    first = cell.robot.state()["seqno"]
    for axis in ("y", "rx"):
        jog.hold(0.6, kind="cartesian", axis=axis, direction=1, frame="tool", speed=1.0)
        cell.robot.wait_stopped()
    velocities = np.abs(np.array(cell.robot.setpoints(first)["velocity"]))
    limits = np.array([j.max_velocity for j in INFO.joints])
    assert np.all(velocities <= limits * (1 + 1e-6))
    assert velocities.max() < 0.5 * limits.max()  # it slowed down; it did not race
    assert not cell.robot.state()["flags"]["error"]


@pytest.mark.parametrize(
    ("kind", "axis", "frame", "step"),
    [
        ("cartesian", "x", "base", 0.001),
        ("cartesian", "z", "base", 0.0001),
        ("cartesian", "y", "tool", 0.001),
        ("cartesian", "rx", "base", math.radians(1)),
        ("cartesian", "rz", "tool", math.radians(0.1)),
        ("joint", 1, "base", math.radians(1)),
    ],
)
def test_incremental_steps_land_on_the_increment(
    cell: Cell, jog: JogClient, kind: str, axis: Any, frame: str, step: float
) -> None:
    before_q = cell.robot.q()
    before = tcp(before_q)
    press = jog.press(kind=kind, axis=axis, frame=frame, direction=1, speed=0.5, step=step)
    jog.send({"type": "release", "press": press})  # a tap: the step completes anyway
    assert jog.status(press, ("done", "halted", "refused"))["state"] == "done"
    after_q = cell.robot.q()
    after = tcp(after_q)
    if kind == "joint":
        assert after_q[axis] - before_q[axis] == pytest.approx(step, abs=math.radians(0.05))
        return
    expected = before.copy()
    index = "xyz".index(axis[-1])
    unit = np.eye(3)[index]
    if axis in ("x", "y", "z"):
        offset = unit * step if frame == "base" else before.rotation @ unit * step
        expected.translation = before.translation + offset
    else:
        turn = pin.exp3(unit * step)
        expected.rotation = turn @ before.rotation if frame == "base" else before.rotation @ turn
    assert np.abs(after.translation - expected.translation).max() < 1e-4  # 0.1 mm
    angle = np.linalg.norm(pin.log3(after.rotation.T @ expected.rotation))
    assert angle < math.radians(0.05)


def test_the_tcp_never_exceeds_250_mm_s_in_manual_mode(cell: Cell, jog: JogClient) -> None:
    stretched = np.array(INFO.home)
    stretched[1], stretched[2] = -0.3, 0.3  # arm reaching out: base rotation is fast at the TCP
    cell.place(stretched)
    first = cell.robot.state()["seqno"]
    jog.hold(0.8, kind="joint", axis=0, direction=1, speed=1.0)
    jog.hold(0.8, kind="cartesian", axis="x", direction=-1, frame="base", speed=1.0)
    jog.hold(0.6, kind="cartesian", axis="rz", direction=1, frame="tool", speed=1.0)
    cell.robot.wait_stopped()
    speeds = tcp_speeds(cell.robot.setpoints(first))
    assert speeds.max() <= 0.25 * 1.01  # 1 % for finite differences of 2 ms samples
    assert speeds.max() > 0.2  # the cap was reached, so this test can fail


def test_move_to_a_pose_waypoint_in_the_world_frame(cell: Cell, jog: JogClient) -> None:
    jog.hold(0.4, kind="cartesian", axis="y", direction=1, frame="base", speed=0.5)
    cell.robot.wait_stopped()
    taught = cell.runtime.api(
        "POST",
        "/jog/robots/robot/teach",
        json={"name": "pick_above", "kind": "pose", "frame": "world"},
    )
    assert taught.status_code == 201, taught.text
    target = tcp(cell.robot.q())
    again = cell.runtime.api(
        "POST", "/jog/robots/robot/teach", json={"name": "pick_above", "kind": "pose"}
    )
    assert again.json()["error"]["code"] == "exists"
    jog.hold(0.4, kind="cartesian", axis="z", direction=-1, frame="base", speed=0.5)
    jog.hold(0.3, kind="cartesian", axis="ry", direction=1, frame="base", speed=0.5)
    cell.robot.wait_stopped()
    assert jog.move_to("pick_above")["state"] == "done"
    reached = tcp(cell.robot.q())
    assert np.abs(reached.translation - target.translation).max() < 1e-4
    assert np.linalg.norm(pin.log3(reached.rotation.T @ target.rotation)) < 1e-3
    listed = cell.runtime.api("GET", "/jog/robots/robot/waypoints").json()
    assert "pick_above" in [w["name"] for w in listed]


def test_move_to_stops_when_the_button_is_let_go(cell: Cell, jog: JogClient) -> None:
    far = np.array(INFO.home) + np.array([1.2, 0.3, -0.4, 0.3, 0.5, 1.0])
    cell.runtime.api(
        "PUT",
        "/variables/far_away",
        json={"type": "joint_waypoint", "value": {"joints": far.tolist(), "robot": "robot"}},
    )
    press = jog.hold(0.4, type="move_to", waypoint="far_away", speed=0.5)
    assert jog.status(press, ("stopped", "halted", "done"))["state"] == "stopped"
    cell.robot.wait_stopped()
    assert np.abs(cell.robot.q() - far).max() > 0.3  # it did not get there on its own
    stopped = cell.robot.q()
    first = cell.robot.state()["seqno"]
    ended = jog.move_to("far_away")
    assert ended["state"] == "done", (ended["reason"], ended["message"])
    assert np.abs(cell.robot.q() - far).max() < 1e-6
    # Along the straight joint line that was checked for collisions, all the way (issue 31:
    # the simulator tracked the streamed positions joint by joint, 0.02 rad off it).
    followed = np.array(cell.robot.setpoints(first)["position"])
    off = float(np.max(distances_to_polyline(np.array([stopped, far]), followed)))
    assert off < 1e-4, f"{off:.4f} rad off the joint line"


def test_move_to_pushed_off_its_path_is_stopped_as_a_protective_stop(
    cell: Cell, jog: JogClient
) -> None:
    """Move to follows the straight joint line that was checked for collisions, under the
    path monitor (issue 31): a hand pushing the arm off it ends the press `halted` with
    `path_deviation`, and the robot stays in a protective stop until errors are reset."""
    start = np.array(INFO.home)
    far = start + np.array([1.2, 0.0, 0.0, 0.0, 0.0, 0.0])  # the base turns
    cell.runtime.api(
        "PUT",
        "/variables/base_turned",
        json={"type": "joint_waypoint", "value": {"joints": far.tolist(), "robot": "robot"}},
    )
    press = jog.press(type="move_to", waypoint="base_turned", speed=0.3)
    try:
        with jog.held(press):
            wait_for(lambda: cell.robot.q()[0] > start[0] + 0.1, 10, what="the move under way")
            pushed = cell.robot.http.put("/sim/hand", json={"velocity": [0, 0.3, 0, 0, 0, 0]})
            assert pushed.status_code == 200, pushed.text
            ended = jog.status(press, ("halted", "stopped", "done", "refused"))
    finally:
        cell.robot.http.put("/sim/hand", json={"velocity": [0.0] * 6})
    assert (ended["state"], ended["reason"]) == ("halted", "path_deviation"), ended
    assert re.search(r"left (its|their) planned path", ended["message"]), ended["message"]
    cell.robot.wait_stopped()
    assert np.abs(cell.robot.q() - far).max() > 0.3  # it did not go on
    state = cell.robot.state()
    assert state["flags"]["protective_stop"] and state["flags"]["error"]
    assert "planned path" in state["error_message"]


def test_move_to_through_an_obstacle_is_refused_and_nothing_moves(
    cell: Cell, jog: JogClient
) -> None:
    """Move-to passes the motion service's collision checks: the posts stand between LEFT
    and RIGHT, so a held Move-to RIGHT is refused with the pair, and no setpoint moves."""
    cell.place(LEFT)
    cell.runtime.api(
        "PUT",
        "/variables/beyond_posts",
        json={"type": "joint_waypoint", "value": {"joints": RIGHT, "robot": "robot"}},
    )
    put_posts(cell.runtime)
    try:
        before = cell.robot.q()
        seq = cell.robot.last_command_seq()
        status = jog.move_to("beyond_posts", timeout=10)
        assert status["state"] == "refused"
        assert status["reason"] == "collision"
        assert "post_" in status["message"] and "would hit" in status["message"]
        time.sleep(0.3)
        assert np.abs(cell.robot.q() - before).max() < STILL
        moved = [c for c in cell.robot.commands(seq) if c["type"] != "halt"]
        assert moved == []
        # A step that stays clear still goes.
        step = jog.hold(0.1, kind="joint", axis=5, direction=1, step=0.01, speed=0.5)
        assert jog.status(step, ("done",))["state"] == "done"
    finally:
        clear_posts(cell.runtime)


# 3D mouse -------------------------------------------------------------------------------------


def mouse_recording(path: Path, phases: list[tuple[float, list[int], int]], end: str) -> Path:
    """Reports every 16 ms, as a SpaceMouse sends while deflected: (seconds, raw axes x y z
    rx ry rz, buttons mask) per phase; then silence ("stuck") or an unplug."""
    lines, t = [], 0.0
    for seconds, raw, mask in phases:
        for _ in range(max(1, round(seconds / 0.016))):
            lines.append({"t": t, "report": (b"\x01" + struct.pack("<3h", *raw[:3])).hex()})
            lines.append({"t": t, "report": (b"\x02" + struct.pack("<3h", *raw[3:])).hex()})
            lines.append({"t": t, "report": (b"\x03" + mask.to_bytes(2, "little")).hex()})
            t += 0.016
    if end == "unplug":
        lines.append({"t": t, "event": "unplug"})
    path.write_text("\n".join(json.dumps(line) for line in lines))
    return path


def add_mouse(cell: Cell, home: Path, name: str, recording: Path) -> SpaceMouseProc:
    mouse = SpaceMouseProc(home, name, recording)
    mouse.wait_ready()
    wait_for(lambda: cell.runtime.is_detected(mouse.uuid), 10, what="mouse detected")
    added = cell.runtime.api("POST", "/devices", json={"uuid": mouse.uuid, "local_name": name})
    assert added.status_code == 201, added.text
    wait_for(
        lambda: cell.runtime.api("GET", f"/devices/{name}").json()["status"] == "connected",
        10,
        what="mouse connected",
    )
    return mouse


def bind_mouse(jog: JogClient, device: str, **fields: Any) -> str:
    jog.send(
        {
            "type": "mouse",
            "robot": "robot",
            "token": jog.token,
            "device": device,
            "enabled": True,
            **fields,
        }
    )
    press = f"mouse:{device}"
    status = jog.status(press, ("moving", "refused"))
    assert status["state"] == "moving", status.get("message")
    return press


def test_the_3d_mouse_jogs_and_a_stuck_mouse_stops_the_robot(
    cell: Cell, jog: JogClient, tmp_path: Path
) -> None:
    # Pushed to the right (+x) for a second, then the reports stop while it is deflected.
    recording = mouse_recording(
        tmp_path / "stuck.jsonl", [(1.0, [300, 0, 0, 0, 0, 0], 0)], end="stuck"
    )
    mouse = add_mouse(cell, tmp_path, "mouse", recording)
    try:
        before = tcp(cell.robot.q())
        after_seq = cell.robot.last_command_seq()
        press = bind_mouse(jog, "mouse", frame="base", speed=0.5)
        mouse_http = httpx.post(f"{mouse.url}/replay/start", timeout=5)
        assert mouse_http.status_code == 204
        halted = jog.status(press, ("halted",), timeout=10)
        assert "stopped reporting" in halted["reason"]
        cell.robot.wait_stopped(3)
        moved = tcp(cell.robot.q()).translation - before.translation
        assert moved[0] > 0.005  # to the right, as pushed
        assert np.abs(moved[1:]).max() < 0.1 * moved[0]
        assert any(
            e["type"] == "halt" and e["tag"] == f"{press}:halt"
            for e in cell.robot.commands(after_seq)
        )
    finally:
        mouse.stop()
        cell.runtime.api("DELETE", "/devices/mouse")


def test_an_unplugged_mouse_stops_the_robot_and_buttons_teach(
    cell: Cell, jog: JogClient, tmp_path: Path
) -> None:
    recording = mouse_recording(
        tmp_path / "unplug.jsonl",
        [
            (0.3, [0, 0, 0, 0, 0, 0], 1),  # button 0 pressed: teach a waypoint
            (0.3, [0, 0, 0, 0, 0, 0], 0),
            (0.6, [0, 0, -300, 0, 0, 0], 0),  # lifted (+z), then the cable is pulled
        ],
        end="unplug",
    )
    mouse = add_mouse(cell, tmp_path, "mouse2", recording)
    try:
        before = tcp(cell.robot.q())
        press = bind_mouse(jog, "mouse2", frame="tool", speed=0.5, buttons={"0": "teach"})
        after_seq = cell.robot.last_command_seq()
        httpx.post(f"{mouse.url}/replay/start", timeout=5)
        # Unplugged: the robot halts; the binding waits for the mouse (issue 32).
        away = jog.status(press, ("held", "halted"), timeout=10)
        assert (away["state"], away["reason"]) == ("held", "mouse_away"), away
        assert "disconnected" in away["message"]
        cell.robot.wait_stopped(3)
        assert any(
            e["type"] == "halt" and e["tag"] == f"{press}:halt"
            for e in cell.robot.commands(after_seq)
        )
        taught = [m for m in jog.messages if m.get("type") == "taught"]
        assert len(taught) == 1
        waypoint = cell.runtime.api("GET", f"/variables/{taught[0]['name']}").json()
        assert waypoint["type"] == "joint_waypoint"
        assert np.allclose(waypoint["value"]["joints"], INFO.home, atol=1e-6)
        moved = tcp(cell.robot.q()).translation - before.translation
        tool_z = before.rotation[:, 2]  # pointing down at home: "up" in the tool frame is -z
        assert float(moved @ tool_z) > 0.005
    finally:
        mouse.stop()
        cell.runtime.api("DELETE", "/devices/mouse2")


def test_a_mouse_bound_again_takes_the_new_mode_at_once(
    cell: Cell, jog: JogClient, tmp_path: Path
) -> None:
    """The page's Joints/Base/Tool buttons re-send the binding: the mouse follows them."""
    recording = mouse_recording(
        tmp_path / "lift.jsonl", [(0.8, [0, 0, -300, 0, 0, 0], 0)], end="stuck"
    )
    mouse = add_mouse(cell, tmp_path, "mouse3", recording)
    try:
        before = cell.robot.q()
        press = bind_mouse(jog, "mouse3", mode="cartesian", frame="base", speed=0.5)
        jog.messages.clear()
        again = bind_mouse(jog, "mouse3", mode="joint", frame="base", speed=0.5)
        assert again == press
        assert any(m.get("type") == "mouse_frame" for m in jog.messages)
        httpx.post(f"{mouse.url}/replay/start", timeout=5)
        jog.status(press, ("halted",), timeout=10)  # the recording ends deflected: stuck
        cell.robot.wait_stopped(3)
        moved = np.degrees(cell.robot.q() - before)
        assert moved[2] > 0.5, moved  # the lift axis drives joint 3 in joint mode ...
        others = np.delete(moved, 2)
        assert np.abs(others).max() < 0.05, moved  # ... and nothing else (a Z move would)
    finally:
        mouse.stop()
        cell.runtime.api("DELETE", "/devices/mouse3")
