"""The simulated Panda (7 joints, joint 4's range below zero) jogs like the UR5: every joint
both ways, every Cartesian axis in the base and the tool frame, and with the 3D mouse; each
moves its own way and nothing else beyond 1 mm / 0.5 degrees. (Joint 4 had never moved:
the simulator's limit guard read ruckig's braking extrema, which reported 0 for a joint at
rest, outside that joint's range.)"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, child_env, wait_for
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from tests.integration.test_jog import add_mouse, bind_mouse, mouse_recording

INFO = load_robot_info("panda")
KINEMATICS = Kinematics(INFO)
AXES = ("x", "y", "z", "rx", "ry", "rz")
ACROSS_MM = 1.0
ACROSS_DEG = 0.5


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cell]:
    home = tmp_path_factory.mktemp("panda")
    runtime = Runtime(
        home, extra=["--no-sim"], env=child_env(home, OPENPENDANT_DEADMAN_SECONDS="0.5")
    )
    runtime.wait_ready()
    sim = SimRobotProc(home, "jog-panda", model="panda")
    sim.wait_ready()
    try:
        yield Cell(runtime, sim.uuid)
    finally:
        sim.stop()
        runtime.stop()


@pytest.fixture
def jog(cell: Cell) -> Iterator[JogClient]:
    cell.ready()
    cell.place(INFO.home)
    client = JogClient(cell.runtime, token=cell.token)
    yield client
    client.close()


def tcp(q: np.ndarray[Any, Any]) -> pin.SE3:
    return KINEMATICS.tcp(q).copy()


def motion(before: pin.SE3, after: pin.SE3, frame: str) -> np.ndarray[Any, Any]:
    """Translation (mm) and rotation (degrees) from before to after, in the base frame or in
    the tool frame as it was before."""
    moved = after.translation - before.translation
    turned = pin.log3(after.rotation @ before.rotation.T)
    if frame == "tool":
        moved, turned = before.rotation.T @ moved, before.rotation.T @ turned
    return np.concatenate((moved * 1000, np.degrees(turned)))


@pytest.mark.parametrize("joint", range(7))
def test_every_joint_jogs_both_ways_alone(cell: Cell, jog: JogClient, joint: int) -> None:
    for direction in (1, -1):
        before = cell.robot.q()
        jog.hold(0.5, kind="joint", axis=joint, direction=direction, speed=0.5)
        cell.robot.wait_stopped()
        moved = cell.robot.q() - before
        assert moved[joint] * direction > 0.05, (joint, direction, moved)
        assert np.abs(np.delete(moved, joint)).max() < 1e-9


@pytest.mark.parametrize("frame", ["base", "tool"])
@pytest.mark.parametrize("axis", AXES)
def test_every_cartesian_axis_jogs_its_own_way(
    cell: Cell, jog: JogClient, axis: str, frame: str
) -> None:
    index = AXES.index(axis)
    before = tcp(cell.robot.q())
    jog.hold(0.5, kind="cartesian", axis=axis, direction=1, frame=frame, speed=0.5)
    cell.robot.wait_stopped()
    moved = motion(before, tcp(cell.robot.q()), frame)
    assert moved[index] > (5.0 if index < 3 else 2.0), (axis, frame, moved.round(2))
    others = np.delete(moved, index)
    translation = others[: 2 if index < 3 else 3]
    rotation = others[2:] if index < 3 else others[3:]
    assert np.abs(translation).max() < ACROSS_MM, (axis, frame, moved.round(2))
    assert np.abs(rotation).max() < ACROSS_DEG, (axis, frame, moved.round(2))


def test_the_3d_mouse_jogs_the_panda_along_x_only(
    cell: Cell, jog: JogClient, tmp_path: Path
) -> None:
    recording = mouse_recording(
        tmp_path / "push.jsonl", [(1.0, [300, 0, 0, 0, 0, 0], 0), (0.5, [0] * 6, 0)], end="hold"
    )
    mouse = add_mouse(cell, tmp_path, "mouse", recording)
    try:
        before = tcp(cell.robot.q())
        bind_mouse(jog, "mouse", frame="base", speed=0.5)
        assert httpx.post(f"{mouse.url}/replay/start", timeout=5).status_code == 204
        wait_for(lambda: motion(before, tcp(cell.robot.q()), "base")[0] > 20, 10, what="moved +x")
        cell.robot.wait_stopped(5)
        moved = motion(before, tcp(cell.robot.q()), "base")
        assert np.abs(moved[1:3]).max() < ACROSS_MM, moved.round(2)
        assert np.abs(moved[3:]).max() < ACROSS_DEG, moved.round(2)
    finally:
        jog.send({"type": "mouse", "robot": "robot", "device": "mouse", "enabled": False})
        mouse.stop()
        cell.runtime.api("DELETE", "/devices/mouse")


def test_freedrive_is_refused_on_a_robot_without_it(cell: Cell, jog: JogClient) -> None:
    press = jog.press(type="freedrive")
    refused = jog.status(press, ("refused", "moving"))
    assert (refused["state"], refused["reason"]) == ("refused", "no_freedrive")
    assert "cannot be moved by hand" in refused["message"]
