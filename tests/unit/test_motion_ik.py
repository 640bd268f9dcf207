"""Inverse kinematics of the motion service: round trips on random reachable poses, the
solution nearest the seed, unreachable poses refused."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.robotics.kinematics import Kinematics, Unreachable
from openpendant.runtime.robotics.robot_info import load_robot_info


@pytest.mark.parametrize("model", ["ur5", "panda"])
def test_round_trip_on_random_reachable_poses(model: str) -> None:
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    rng = np.random.default_rng(11)
    seed = np.array(info.home)
    lower = np.maximum(kinematics.lower, -np.pi)
    upper = np.minimum(kinematics.upper, np.pi)
    for _ in range(100):
        target = kinematics.tcp(rng.uniform(lower, upper)).copy()
        solution = kinematics.inverse(target, seed)
        reached = kinematics.tcp(solution)
        assert np.linalg.norm(reached.translation - target.translation) < 1e-6
        assert np.linalg.norm(pin.log3(reached.rotation.T @ target.rotation)) < 1e-6
        assert np.all(solution >= kinematics.lower)
        assert np.all(solution <= kinematics.upper)


def test_the_solution_nearest_the_seed_is_chosen() -> None:
    """A UR wrist can turn ±2π: the same pose has solutions a full turn apart; the one next
    to the current configuration is the answer, not a full turn of the wrist."""
    info = load_robot_info("ur5")
    kinematics = Kinematics(info)
    seed = np.array([0.3, -1.4, 1.5, -1.7, -1.6, 5.0])
    target = kinematics.tcp(seed + 0.05).copy()
    solution = kinematics.inverse(target, seed)
    assert np.max(np.abs(solution - seed)) < 0.2


@pytest.mark.parametrize(
    "position", [[3.0, 0.0, 0.5], [0.0, 0.0, 2.0], [0.05, 0.02, -1.5]], ids=str
)
def test_unreachable_poses_are_refused(position: list[float]) -> None:
    info = load_robot_info("ur5")
    kinematics = Kinematics(info)
    with pytest.raises(Unreachable):
        kinematics.inverse(pin.SE3(np.eye(3), np.array(position)), info.home)
