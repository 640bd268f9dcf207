"""The velocity QP's answer, one cycle at a time, as a reactive move and a Cartesian jog
use it (issue 31): while the joints cannot yet reach the velocity asked for, the TCP still
moves in the direction asked, only slower; and a twist faster than the TCP cap is capped
as asked, not turned."""

from __future__ import annotations

import numpy as np
import pytest

from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.velocity import VelocityController

PERIOD = 0.01


def controller(model: str) -> tuple[VelocityController, np.ndarray]:
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    joints = info.joints
    return (
        VelocityController(
            kinematics,
            np.array([j.max_velocity for j in joints]),
            np.array([j.max_acceleration for j in joints]),
            PERIOD,
        ),
        np.array(info.home),
    )


def turned(velocity: np.ndarray, jacobian: np.ndarray, twist: np.ndarray) -> float:
    """The angle (rad) between the TCP's linear velocity and the one asked for."""
    moved = jacobian[:3] @ velocity
    cosine = moved @ twist[:3] / (np.linalg.norm(moved) * np.linalg.norm(twist[:3]))
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)))


@pytest.mark.parametrize("model", ["ur5", "panda"])
@pytest.mark.parametrize("cap", [None, 0.25])
def test_speeding_up_from_rest_keeps_the_direction(model: str, cap: float | None) -> None:
    velocity_qp, q = controller(model)
    jacobian = velocity_qp.kinematics.jacobian(q)
    twist = np.array([-0.3, 0.3, 0.15, 0.0, 0.0, 0.0])  # 0.45 m/s
    previous = np.zeros(q.size)
    for cycle in range(20):
        step = velocity_qp.from_twist(q, twist, cap, previous)
        change = np.abs(step.velocity - previous)
        assert np.all(change <= velocity_qp.max_acceleration * PERIOD + 1e-9)
        # It was up to 0.44 rad off while the per-joint bounds were active.
        assert turned(step.velocity, jacobian, twist) < 1e-3, cycle
        previous = step.velocity
    speed = float(np.linalg.norm(jacobian[:3] @ previous))
    assert speed == pytest.approx(cap or np.linalg.norm(twist[:3]), rel=1e-3)  # got there
