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


class Unreachable(InvalidValue):
    code = "unreachable"


class Kinematics:
    """Kinematics of one robot in its base frame: TCP pose, Jacobians, inverse kinematics.
    Joint vectors are in the robot-info joint order. Not thread-safe: one per thread."""

    def __init__(self, info: RobotInfo, urdf: Path | None = None) -> None:
        self.info = info
        path = urdf or resolve_package_uri(info.urdf)
        self.model, self._order = load_urdf_model(path, info.joint_names)
        for frame in (info.base_link, info.flange_link):
            if not self.model.existFrame(frame):
                raise InvalidValue(f"frame {frame!r} is not in {path.name}")
        self._base = self.model.getFrameId(info.base_link)
        flange = self.model.frames[self.model.getFrameId(info.flange_link)]
        # The TCP becomes a frame of the model, so Jacobians can be taken at it directly.
        self._tcp = self.model.addFrame(
            pin.Frame(
                "openpendant_tcp",
                flange.parentJoint,
                self.model.getFrameId(info.flange_link),
                flange.placement * pose_to_se3(info.tcp),
                pin.FrameType.OP_FRAME,
            )
        )
        self.data = self.model.createData()
        self._q: FloatArray = pin.neutral(self.model)
        self.lower = np.array([j.lower for j in info.joints])
        self.upper = np.array([j.upper for j in info.joints])

    def _set(self, joints: FloatArray | list[float]) -> FloatArray:
        self._q[self._order] = joints
        return self._q

    def tcp(self, joints: FloatArray | list[float]) -> pin.SE3:
        """TCP pose in the base frame."""
        q = self._set(joints)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self._base].actInv(self.data.oMf[self._tcp])

    def tcp_pose(self, joints: FloatArray | list[float]) -> Pose:
        return se3_to_pose(self.tcp(joints))

    def jacobian(self, joints: FloatArray | list[float]) -> FloatArray:
        """6-by-n Jacobian of the TCP: linear velocity of the TCP point and angular velocity,
        both along the base frame's axes."""
        q = self._set(joints)
        pin.framesForwardKinematics(self.model, self.data, q)
        world = pin.computeFrameJacobian(
            self.model, self.data, q, self._tcp, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        rotation = self.data.oMf[self._base].rotation.T
        jacobian: FloatArray = np.vstack((rotation @ world[:3], rotation @ world[3:]))
        return jacobian[:, self._order]

    def inverse(
        self,
        target: pin.SE3,
        seed: FloatArray | list[float],
        *,
        tolerance: float = 1e-9,
        max_iterations: int = 200,
        damping: float = 1e-8,
    ) -> FloatArray:
        """Joint positions that put the TCP at `target` (base frame), found by damped least
        squares from `seed` within the joint limits: the solution nearest the seed."""
        base = self._base_placement()
        goal = base * target
        q_model = self._set(np.clip(np.asarray(seed, dtype=float), self.lower, self.upper)).copy()
        for _ in range(max_iterations):
            pin.framesForwardKinematics(self.model, self.data, q_model)
            current = self.data.oMf[self._tcp]
            error = pin.log6(current.actInv(goal)).vector
            if np.linalg.norm(error) < tolerance:
                return q_model[self._order].copy()
            jac = pin.computeFrameJacobian(
                self.model, self.data, q_model, self._tcp, pin.ReferenceFrame.LOCAL
            )[:, self._order]
            step = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), error)
            q = np.clip(q_model[self._order] + step, self.lower, self.upper)
            q_model[self._order] = q
        raise Unreachable("no joint position reaches that pose within the joint limits")

    def _base_placement(self) -> pin.SE3:
        pin.framesForwardKinematics(self.model, self.data, self._q)
        return self.data.oMf[self._base].copy()
