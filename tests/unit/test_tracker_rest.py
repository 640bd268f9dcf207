"""A joint tracker that holds comes to rest exactly (ruckig leaves 1e-25 rad/s behind, for
ever), and at rest it stays where it is without planning anything."""

from __future__ import annotations

import numpy as np
import pytest

from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.tracker import JointTracker

pytestmark = pytest.mark.concurrent

UR5 = load_robot_info("ur5")


@pytest.mark.parametrize(
    "velocity",
    [[0.5, -0.3, 0.2, 0.7, -0.9, 1.0], [0.01, 0, 0, 0, 0, 0], [3.0] * 6],
)
def test_a_held_joint_comes_to_rest_exactly_and_stays(velocity: list[float]) -> None:
    tracker = JointTracker(UR5.joints, 0.002, np.array(UR5.home))
    for _ in range(300):
        tracker.step_velocity(np.array(velocity))
    braking = 0
    while tracker.velocity.any() or tracker.acceleration.any():
        tracker.hold()
        braking += 1
        assert braking < 2000, "never quite at rest"
    at_rest = tracker.position.copy()
    for _ in range(100):
        tracker.hold()
    assert np.array_equal(tracker.position, at_rest)
    # Moving again from there is smooth: it starts from rest.
    tracker.step_velocity(np.array(velocity))
    assert np.abs(tracker.velocity).max() < 0.1
