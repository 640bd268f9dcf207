"""The checks every robot command passes before anything moves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from openpendant.runtime.interfaces.limits import JointLimitChecker
from openpendant.runtime.interfaces.robot import JointTrajectory, TrajectoryWaypoint
from openpendant.runtime.kit.errors import RobotError
from openpendant.runtime.robotics.robot_info import load_robot_info


@pytest.fixture(scope="module")
def checker() -> JointLimitChecker:
    return JointLimitChecker(load_robot_info("panda"))


HOME = [0.0, -0.7854, 0.0, -2.3562, 0.0, 1.5708, 0.7854]


@pytest.mark.parametrize(
    ("values", "code"),
    [
        ([0.0] * 6, "wrong_length"),
        ([math.nan] + HOME[1:], "not_finite"),
        ([math.inf] + HOME[1:], "not_finite"),
        (HOME[:3] + [0.0] + HOME[4:], "position_limit"),  # joint 4 must stay below -0.0698
        ([3.0] + HOME[1:], "position_limit"),
    ],
)
def test_bad_positions_are_refused(
    checker: JointLimitChecker, values: list[float], code: str
) -> None:
    with pytest.raises(RobotError) as err:
        checker.positions(values)
    assert err.value.code == code


def test_velocity_over_the_limit_names_the_joint(checker: JointLimitChecker) -> None:
    with pytest.raises(RobotError, match=r"joint 5 \(panda_joint5\)"):
        checker.velocities([0, 0, 0, 0, 2.7, 0, 0])
    assert checker.velocities([0, 0, 0, 0, 2.6, 0, 0])[4] == 2.6


def traj(*points: tuple[float, list[float]]) -> JointTrajectory:
    return JointTrajectory(
        waypoints=[TrajectoryWaypoint(time_from_start=t, position=p) for t, p in points]
    )


def test_trajectory_starts_from_the_current_position(checker: JointLimitChecker) -> None:
    start = np.array(HOME)
    goal = list(start + 0.1)
    checked = checker.trajectory(traj((1.0, goal)), start)
    assert list(checked.times) == [0.0, 1.0]
    assert np.allclose(checked.positions[0], start)
    with pytest.raises(RobotError, match="current position"):
        checker.trajectory(traj((0.0, goal), (1.0, goal)), start)


def test_trajectory_too_fast_or_out_of_order_is_refused(checker: JointLimitChecker) -> None:
    start = np.array(HOME)
    far = list(start + np.array([2.0, 0, 0, 0, 0, 0, 0]))
    with pytest.raises(RobotError) as err:
        checker.trajectory(traj((0.5, far)), start)  # 4 rad/s on joint 1
    assert err.value.code == "velocity_limit"
    near = list(start + 0.01)
    with pytest.raises(RobotError, match="strictly increase"):
        checker.trajectory(traj((1.0, near), (1.0, near)), start)


@pytest.mark.parametrize(
    ("spoil", "message"),
    [
        ("position", r"waypoint 3 position 3\.0000 rad of joint 1 \(panda_joint1\)"),
        ("length", r"waypoint 3 position has 6 values"),
        ("velocity", r"waypoint 3 velocity 9\.0000 rad/s of joint 3 \(panda_joint3\)"),
        ("acceleration", r"waypoint 3 acceleration 99\.0000 rad/s² of joint 7"),
        ("jump", r"segment 3 speed"),
    ],
)
def test_a_long_trajectory_is_refused_at_its_first_bad_waypoint(
    checker: JointLimitChecker, spoil: str, message: str
) -> None:
    """Checked all at once (a thousand waypoints, one by one, held a driver's loop 130 ms),
    still named by the first waypoint that fails."""
    start = np.array(HOME)
    points = []
    for k in range(1000):
        q = (start + 0.0001 * k).tolist()
        v, a = [0.025] * 7, [0.0] * 7
        if k in (3, 7):  # the first bad one is named, not a later one
            if spoil == "position":
                q[0] = 3.0
            elif spoil == "length":
                q = q[:6]
            elif spoil == "velocity":
                v[2] = 9.0
            elif spoil == "acceleration":
                a[6] = 99.0
            elif spoil == "jump":
                q[0] += 0.5
        points.append(
            TrajectoryWaypoint(
                time_from_start=(k + 1) * 0.004, position=q, velocity=v, acceleration=a
            )
        )
    with pytest.raises(RobotError, match=message):
        checker.trajectory(JointTrajectory(waypoints=points), start)
    clean = [
        TrajectoryWaypoint(
            time_from_start=(k + 1) * 0.004,
            position=(start + 0.0001 * k).tolist(),
            velocity=[0.025] * 7,
            acceleration=[0.0] * 7,
        )
        for k in range(1000)
    ]
    checked = checker.trajectory(JointTrajectory(waypoints=clean), start)
    assert checked.positions.shape == (1001, 7) and checked.velocities is not None
    assert np.allclose(checked.velocities[1:], 0.025) and np.allclose(checked.velocities[0], 0)
