"""A URDF made from a Robot Raconteur kinematic chain (runtime/robotics/chain_urdf.py) puts
the flange where the chain's own product-of-exponentials formula does, for any joints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from pydantic import ValidationError

from openpendant.runtime.robotics.chain_urdf import ChainJoint, KinematicChain, chain_urdf

# Universal Robots' UR5 as Robot Raconteur's example robot info gives it (H and P).
H = [[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 1, 0], [0, 0, -1], [0, 1, 0]]
P = [
    [0, 0, 0.089159],
    [0, 0.13585, 0],
    [0, -0.1197, 0.425],
    [0, 0, 0.39225],
    [0, 0.093, 0],
    [0, 0, 0.09465],
    [0, 0.0823, 0],
]
# The flange turned a quarter about x, so the orientation counts too.
FLANGE = [np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)]


def chain(kinds: list[str] | None = None) -> KinematicChain:
    kinds = kinds or ["revolute"] * 6
    joints = [
        ChainJoint(
            name=f"joint_{i + 1}",
            kind=kinds[i],
            axis=[float(v) for v in H[i]],
            offset=[float(v) for v in P[i]],
            lower=-6.28,
            upper=6.28,
            max_velocity=3.14,
        )
        for i in range(6)
    ]
    return KinematicChain(
        joints=joints, flange_offset=[float(v) for v in P[6]], flange_orientation=FLANGE
    )


def rot(axis: np.ndarray, angle: float) -> np.ndarray:
    turned: np.ndarray = pin.exp3(np.asarray(axis, dtype=float) * angle)
    return turned


def poe(q: np.ndarray, kinds: list[str]) -> pin.SE3:
    """The chain's forward kinematics, written out: general-robotics-toolbox's fwdkin."""
    p = np.array(P[0], dtype=float)
    r = np.eye(3)
    for i in range(6):
        if kinds[i] == "revolute":
            r = r @ rot(np.array(H[i]), q[i])
        else:
            p = p + r @ (np.array(H[i], dtype=float) * q[i])
        p = p + r @ np.array(P[i + 1], dtype=float)
    x, y, z, w = FLANGE
    return pin.SE3(r @ pin.Quaternion(w, x, y, z).toRotationMatrix(), p)


@pytest.mark.parametrize(
    "kinds",
    [["revolute"] * 6, ["prismatic", "revolute", "revolute", "prismatic", "revolute", "revolute"]],
)
def test_the_flange_is_where_the_chain_puts_it(tmp_path: Path, kinds: list[str]) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(chain_urdf("arm", chain(kinds), ("base", "flange")))
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    flange = model.getFrameId("flange")
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(-3, 3, 6)
        pin.framesForwardKinematics(model, data, q)
        expected = poe(q, kinds)
        assert np.allclose(data.oMf[flange].translation, expected.translation, atol=1e-9)
        assert np.allclose(data.oMf[flange].rotation, expected.rotation, atol=1e-9)


def test_a_chain_with_a_bent_axis_is_refused() -> None:
    with pytest.raises(ValidationError, match="unit vector"):
        ChainJoint(name="j", axis=[0, 0, 2], offset=[0, 0, 0], lower=-1, upper=1, max_velocity=1)
