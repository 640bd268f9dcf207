"""Robot-info files and forward kinematics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import available_models, load_robot_info


def test_required_models_are_available() -> None:
    assert {"ur3", "ur5", "ur10", "panda"} <= set(available_models())


@pytest.mark.parametrize("model", ["ur3", "ur5", "ur10", "panda"])
def test_every_model_loads_with_complete_limits(model: str) -> None:
    info = load_robot_info(model)
    assert info.dof == (7 if model == "panda" else 6)
    for joint in info.joints:
        assert joint.lower < joint.upper
        assert joint.max_velocity > 0 and joint.max_acceleration > 0
    pose = Kinematics(info).tcp_pose(info.home)
    assert np.linalg.norm(pose.position) < 1.5


# Every UR model against UR's DH parameters: tests/unit/test_ur_models.py.


def test_panda_limits_come_from_the_urdf() -> None:
    info = load_robot_info("panda")
    assert info.joints[3].lower == pytest.approx(-3.0718)
    assert info.joints[3].upper == pytest.approx(-0.0698)
    assert info.joints[0].max_velocity == pytest.approx(2.175)


def test_unknown_model_names_the_known_ones() -> None:
    with pytest.raises(NotFound, match=r"known: .*ur5"):
        load_robot_info("abb-irb-9999")


def test_robot_info_with_a_joint_missing_from_the_urdf_is_rejected(tmp_path: Path) -> None:
    source = (Path(__file__).parents[2] / "deploy" / "robots" / "ur5.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(source.replace("wrist_3_joint", "wrist_9_joint"))
    with pytest.raises(InvalidValue, match="wrist_9_joint"):
        load_robot_info(str(bad))


def test_home_outside_the_limits_is_rejected(tmp_path: Path) -> None:
    source = (Path(__file__).parents[2] / "deploy" / "robots" / "ur5.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(source.replace("home: [0.0, -1.5708, 1.5708", "home: [0.0, -1.5708, 9.0"))
    with pytest.raises(InvalidValue, match="home"):
        load_robot_info(str(bad))


@pytest.mark.parametrize("model", ["ur5", "panda"])
def test_jacobian_matches_finite_differences(model: str) -> None:
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = np.clip(
            np.array(info.home) + rng.uniform(-0.4, 0.4, info.dof),
            kinematics.lower,
            kinematics.upper,
        )
        jacobian = kinematics.jacobian(q)
        before = kinematics.tcp(q)
        eps = 1e-7
        for j in range(info.dof):
            dq = np.zeros(info.dof)
            dq[j] = eps
            after = kinematics.tcp(q + dq)
            linear = (after.translation - before.translation) / eps
            angular = pin.log3(after.rotation @ before.rotation.T) / eps
            assert np.allclose(jacobian[:3, j], linear, atol=1e-6)
            assert np.allclose(jacobian[3:, j], angular, atol=1e-6)


@pytest.mark.parametrize("model", ["ur5", "panda"])
def test_inverse_kinematics_round_trip_near_the_seed(model: str) -> None:
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    rng = np.random.default_rng(3)
    seed = np.array(info.home)
    for _ in range(50):
        q = np.clip(seed + rng.uniform(-0.5, 0.5, info.dof), kinematics.lower, kinematics.upper)
        target = kinematics.tcp(q)
        solution = kinematics.inverse(target, seed)
        reached = kinematics.tcp(solution)
        assert np.allclose(reached.translation, target.translation, atol=1e-8)
        assert np.linalg.norm(pin.log3(reached.rotation.T @ target.rotation)) < 1e-8
        assert np.all(solution >= kinematics.lower)
        assert np.all(solution <= kinematics.upper)


def test_an_unreachable_pose_is_refused() -> None:
    kinematics = Kinematics(load_robot_info("ur5"))
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.5]))
    with pytest.raises(InvalidValue) as err:
        kinematics.inverse(far, load_robot_info("ur5").home)
    assert err.value.code == "unreachable"
