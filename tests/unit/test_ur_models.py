"""Universal Robots' robot-info files against UR's published figures: DH parameters, joint
speeds, payloads, reach; the CB3 URDFs and the DH parameters against each other; the bodies
made from DH parameters around the arms they stand for."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from openpendant.device_drivers.ur_rtde.models import model_mismatch
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.paths import ROBOTS_DIR, resolve_package_uri
from openpendant.runtime.robotics import geometry
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_body import RobotBody
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.webui.server import robot_file_path

# UR's DH parameters (d1, a2, a3, d4, d5, d6 in m; "DH parameters for calculations of
# kinematics and dynamics", universal-robots.com), the manuals' joint speeds (°/s), rated
# payload (kg) and reach (mm).
DH = {
    "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
    "ur5": (0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823),
    "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
    "ur3e": (0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921),
    "ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
    "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
    "ur16e": (0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655),
    "ur20": (0.2363, -0.862, -0.7287, 0.201, 0.1593, 0.1543),
    "ur30": (0.2363, -0.637, -0.5037, 0.201, 0.1593, 0.1543),
}
SPEEDS = {
    "ur3": (180,) * 3 + (360,) * 3,
    "ur5": (180,) * 6,
    "ur10": (120,) * 2 + (180,) * 4,
    "ur3e": (180,) * 3 + (360,) * 3,
    "ur5e": (180,) * 6,
    "ur10e": (120,) * 2 + (180,) * 4,
    "ur16e": (120,) * 2 + (180,) * 4,
    "ur20": (120, 120, 150, 210, 210, 210),
    "ur30": (120, 120, 150, 210, 210, 210),
}
PAYLOAD_REACH = {
    "ur3": (3, 500),
    "ur5": (5, 850),
    "ur10": (10, 1300),
    "ur3e": (3, 500),
    "ur5e": (5, 850),
    "ur10e": (12.5, 1300),
    "ur16e": (16, 900),
    "ur20": (20, 1750),
    "ur30": (30, 1300),
}
ALPHA = (math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0)
# The CB3 arms' sideways offsets of the upper arm and forearm tubes (UR's ROS description).
CB3_OFFSETS = {"ur3": (0.1198, 0.0275), "ur5": (0.13585, 0.0165), "ur10": (0.220941, 0.049042)}
E_SERIES_OF = {"ur3": ["ur3e"], "ur5": ["ur5e"], "ur10": ["ur10e", "ur16e"]}


def dh_forward(dh: tuple[float, ...], q: np.ndarray) -> np.ndarray:
    """The flange in the base frame by the textbook DH product (not the product's code)."""
    d = (dh[0], 0, 0, dh[3], dh[4], dh[5])
    a = (0, dh[1], dh[2], 0, 0, 0)
    pose = np.eye(4)
    for qi, di, ai, alpha in zip(q, d, a, ALPHA, strict=True):
        ct, st, ca, sa = math.cos(qi), math.sin(qi), math.cos(alpha), math.sin(alpha)
        pose = pose @ np.array(
            [
                [ct, -st * ca, st * sa, ai * ct],
                [st, ct * ca, -ct * sa, ai * st],
                [0, sa, ca, di],
                [0, 0, 0, 1],
            ]
        )
    return pose


def flange(kinematics: Kinematics, q: np.ndarray) -> np.ndarray:
    """The flange in the base frame as the product works it out (the files' TCP is 0)."""
    assert kinematics.info.tcp.position == [0, 0, 0]
    return np.asarray(kinematics.tcp(q).homogeneous)


def random_configurations(count: int, seed: int = 7) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-math.pi, math.pi, 6) for _ in range(count)]


@pytest.mark.parametrize("model", sorted(DH))
def test_the_kinematics_are_ur_s_dh_parameters(model: str) -> None:
    """CB3: example-robot-data's URDF; e-Series: the URDF made from the file's DH. Either
    way the flange is where UR's DH parameters put it."""
    kinematics = Kinematics(load_robot_info(model))
    for q in random_configurations(40):
        ours, theirs = flange(kinematics, q), dh_forward(DH[model], q)
        assert np.linalg.norm(ours[:3, 3] - theirs[:3, 3]) < 1e-6  # m
        turn = pin.log3(ours[:3, :3].T @ theirs[:3, :3])
        assert np.linalg.norm(turn) < 1e-6  # rad


@pytest.mark.parametrize("model", sorted(DH))
def test_the_limits_payload_and_reach_are_the_manual_s(model: str) -> None:
    dh, speeds, (payload, reach) = DH[model], SPEEDS[model], PAYLOAD_REACH[model]
    info = load_robot_info(model)
    assert [j.name for j in info.joints] == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    assert [j.max_velocity for j in info.joints] == pytest.approx([math.radians(s) for s in speeds])
    for joint in info.joints:
        # ±360° on every joint; the elbow ±180° (the upper arm stops it before that).
        limit = math.pi if joint.name == "elbow_joint" else 2 * math.pi
        assert (joint.lower, joint.upper) == pytest.approx((-limit, limit))
    assert info.max_payload == payload
    assert f"{payload:g} kg payload, {reach} mm reach" in info.description
    # The arm stretched out (all joints at zero): the flange's distance from the base axis is
    # near the published reach (UR measures it to a point it does not state exactly).
    stretched = dh_forward(dh, np.zeros(6))[:3, 3]
    assert math.hypot(stretched[0], stretched[1]) == pytest.approx(reach / 1000, rel=0.1)


def dh_body(model: str, radii_from: str, home: Path) -> RobotBody:
    """The CB3 `model` made from its DH parameters, with the body radii of `radii_from`."""
    raw = yaml.safe_load((ROBOTS_DIR / f"{radii_from}.yaml").read_text())
    dh = DH[model]
    d, a = (dh[0], 0, 0, dh[3], dh[4], dh[5]), (0, dh[1], dh[2], 0, 0, 0)
    offsets = (None, *CB3_OFFSETS[model], None, None, None)
    for link, di, ai, offset in zip(raw["dh"]["links"], d, a, offsets, strict=True):
        link.update(d=di, a=ai, offset=offset)
    raw["model"] = f"{model}-as-{radii_from}"
    cb3 = load_robot_info(model)
    for joint, limits in zip(raw["joints"], cb3.joints, strict=True):
        joint.update(lower=limits.lower, upper=limits.upper)
    path = home / f"{raw['model']}.yaml"
    path.write_text(yaml.safe_dump(raw))
    info = load_robot_info(str(path))
    urdf = resolve_package_uri(info.urdf)
    return RobotBody("dh", Kinematics(info, urdf), urdf)


@pytest.mark.parametrize(
    ("cb3", "e_series"), [(cb3, e) for cb3, models in E_SERIES_OF.items() for e in models]
)
def test_the_bodies_made_from_dh_wrap_the_real_arm(
    cb3: str, e_series: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """UR publishes no e-Series meshes here, so the e-Series bodies are checked on the CB3
    arm of the same size, whose meshes are here: its DH arm with the e-Series radii holds
    every corner of the CB3 arm's collision meshes, in any pose."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    meshes = RobotBody("mesh", Kinematics(load_robot_info(cb3)))
    envelope = dh_body(cb3, e_series, tmp_path)
    for q in [np.array(meshes.kinematics.info.home), *random_configurations(3)]:
        meshes.place(q)
        envelope.place(q)
        for part in meshes.parts:
            if part.shape.hull is None:  # the tool0 marker box, not the arm
                continue
            vertices, _ = part.shape.hull
            for vertex in vertices[:: max(1, len(vertices) // 40)]:
                point = part.shape.rotation @ vertex + part.shape.translation
                probe = geometry.sphere("probe", 1e-4, pin.SE3(np.eye(3), point))
                probe.place(pin.SE3.Identity())
                gap = min(geometry.proximity(probe, s.shape).distance for s in envelope.parts)
                assert gap <= 0, f"{part.shape.name} sticks out {gap * 1000:.1f} mm at q={q}"


def test_the_biggest_arms_bodies_are_the_ur10e_s_scaled_up() -> None:
    def radii(model: str) -> list[float]:
        raw = yaml.safe_load((ROBOTS_DIR / f"{model}.yaml").read_text())
        return [raw["dh"]["base_radius"], *(link["radius"] for link in raw["dh"]["links"])]

    scale = DH["ur20"][3] / DH["ur10e"][3]  # the wrists' offsets
    for model in ("ur20", "ur30"):
        assert np.all(np.array(radii(model)) >= scale * np.array(radii("ur10e")) - 1e-9)


def test_a_generated_urdf_is_served_to_the_3d_view(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    info = load_robot_info("ur5e")
    package, _, name = info.urdf.removeprefix("package://").partition("/")
    served = robot_file_path(package, name)
    assert served.is_relative_to(tmp_path)
    assert '<robot name="ur5e">' in served.read_text()
    # Made again from the same file: the same name (the view caches robot files by name).
    assert load_robot_info("ur5e").urdf == info.urdf


def write_info(home: Path, **changes: object) -> Path:
    raw = yaml.safe_load((ROBOTS_DIR / "ur5e.yaml").read_text())
    raw.update(changes)
    path = home / "arm.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_a_file_with_urdf_and_dh_is_refused(tmp_path: Path) -> None:
    path = write_info(tmp_path, urdf="package://example-robot-data/robots/ur_description/x")
    with pytest.raises(InvalidValue, match="either 'urdf' or 'dh'"):
        load_robot_info(str(path))


def test_dh_links_must_be_the_joints_in_order(tmp_path: Path) -> None:
    raw = yaml.safe_load((ROBOTS_DIR / "ur5e.yaml").read_text())
    links = raw["dh"]["links"]
    links[0], links[1] = links[1], links[0]
    with pytest.raises(InvalidValue, match="joints, in order"):
        load_robot_info(str(write_info(tmp_path, dh=raw["dh"])))


def test_dh_needs_every_joint_s_limits(tmp_path: Path) -> None:
    raw = yaml.safe_load((ROBOTS_DIR / "ur5e.yaml").read_text())
    del raw["joints"][3]["max_velocity"]
    with pytest.raises(InvalidValue, match="lower, upper and max_velocity"):
        load_robot_info(str(write_info(tmp_path, joints=raw["joints"])))


def test_a_bad_dh_value_is_refused(tmp_path: Path) -> None:
    raw = yaml.safe_load((ROBOTS_DIR / "ur5e.yaml").read_text())
    raw["dh"]["links"][2]["radius"] = float("nan")
    with pytest.raises(InvalidValue, match="radius"):
        load_robot_info(str(write_info(tmp_path, dh=raw["dh"])))


@pytest.mark.parametrize(
    ("model", "reported", "polyscope", "refused"),
    [
        ("ur5e", "UR5", "URSoftware 5.11.1.108318 (Mar 22 2021)", None),
        ("ur5", "UR5", "URSoftware 3.15.7.106331 (Jun 02 2021)", None),
        ("ur20", "UR20", "URSoftware 5.15.0.12345 (Jan 01 2026)", None),
        ("ur5", "UR5", "URSoftware 5.11.1.108318 (Mar 22 2021)", "a UR5 (e-Series), not a ur5"),
        ("ur5e", "UR5", "URSoftware 3.15.7.106331 (Jun 02 2021)", "a UR5 (CB3), not a ur5e"),
        ("ur10e", "UR16", "URSoftware 5.11.1.108318 (Mar 22 2021)", "a UR16 (e-Series)"),
        ("ur5e", "UR5", "no version", "PolyScope 'no version'"),
        ("ur5e", "", "URSoftware 5.11", "an unknown arm"),
        ("my-cell-arm", "UR10", "URSoftware 5.11", None),  # a file of one's own
    ],
)
def test_the_driver_takes_over_only_the_arm_its_file_describes(
    model: str, reported: str, polyscope: str, refused: str | None
) -> None:
    answer = model_mismatch(model, reported, polyscope)
    if refused is None:
        assert answer is None
    else:
        assert answer is not None and refused in answer and "--model" in answer
