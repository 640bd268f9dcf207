"""Robot kinematics from the URDF (pinocchio), in the robot's base frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from runtime.interfaces.common import Pose
from runtime.interfaces.robot import RobotInfo
from runtime.kit.errors import InvalidValue
from runtime.paths import resolve_package_uri

FloatArray = npt.NDArray[np.float64]


def load_urdf_model(urdf: Path, keep_joints: list[str]) -> tuple[pin.Model, list[int]]:
    """The URDF model reduced to `keep_joints` (others locked at zero) and, for each kept
    joint in the given order, its index in the model's configuration vector."""
    full = pin.buildModelFromUrdf(str(urdf))
    names = list(full.names)[1:]
    missing = [n for n in keep_joints if n not in names]
    if missing:
        raise InvalidValue(f"joints not in URDF {urdf.name}: {', '.join(missing)}")
    locked = [full.getJointId(n) for n in names if n not in keep_joints]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
    order = []
    for name in keep_joints:
        joint = model.joints[model.getJointId(name)]
        if joint.nq != 1:
            raise InvalidValue(f"joint {name} is not a single-axis joint")
        order.append(joint.idx_q)
    return model, order


def urdf_joint_limits(model: pin.Model, order: list[int]) -> list[tuple[float, float, float]]:
    """(lower, upper, max_velocity) of each joint in `order`, as the URDF states them."""
    return [
        (
            float(model.lowerPositionLimit[i]),
            float(model.upperPositionLimit[i]),
            float(model.velocityLimit[i]),
        )
        for i in order
    ]


def se3_to_pose(m: pin.SE3) -> Pose:
    quat = pin.Quaternion(m.rotation).coeffs()  # x, y, z, w
    return Pose(position=[float(v) for v in m.translation], orientation=[float(v) for v in quat])


def pose_to_se3(pose: Pose) -> pin.SE3:
    x, y, z, w = pose.orientation
    return pin.SE3(pin.Quaternion(w, x, y, z).toRotationMatrix(), np.array(pose.position))


class Kinematics:
    """Forward kinematics of one robot: TCP pose in the base frame."""

    def __init__(self, info: RobotInfo, urdf: Path | None = None) -> None:
        self.info = info
        path = urdf or resolve_package_uri(info.urdf)
        self.model, self._order = load_urdf_model(path, info.joint_names)
        self.data = self.model.createData()
        for frame in (info.base_link, info.flange_link):
            if not self.model.existFrame(frame):
                raise InvalidValue(f"frame {frame!r} is not in {path.name}")
        self._base = self.model.getFrameId(info.base_link)
        self._flange = self.model.getFrameId(info.flange_link)
        self._tcp = pose_to_se3(info.tcp)
        self._q = pin.neutral(self.model)

    def tcp(self, joints: FloatArray | list[float]) -> pin.SE3:
        self._q[self._order] = joints
        pin.framesForwardKinematics(self.model, self.data, self._q)
        base = self.data.oMf[self._base]
        return base.actInv(self.data.oMf[self._flange]) * self._tcp

    def tcp_pose(self, joints: FloatArray | list[float]) -> Pose:
        return se3_to_pose(self.tcp(joints))
