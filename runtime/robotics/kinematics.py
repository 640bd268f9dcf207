"""Robot kinematics from the URDF (pinocchio), in the robot's base frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.words import words
from openpendant.runtime.paths import resolve_package_uri

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
        self._flange = self.model.getFrameId(info.flange_link)
        flange = self.model.frames[self._flange]
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

    @property
    def order(self) -> list[int]:
        """Where each robot-info joint sits in the model's configuration vector."""
        return self._order

    @property
    def tcp_frame(self) -> int:
        return int(self._tcp)

    @property
    def base_frame(self) -> int:
        return int(self._base)

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

    def flange(self, joints: FloatArray | list[float]) -> pin.SE3:
        """The flange's pose in the base frame (what a tag or tool is mounted on)."""
        q = self._set(joints)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self._base].actInv(self.data.oMf[self._flange])

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
        tolerance: float = 1e-10,
        restarts: int = 40,
    ) -> FloatArray:
        """Joint positions within the limits that put the TCP at `target` (base frame): the
        solution reached from `seed` (the current configuration) when there is one, else the
        one nearest the seed among those found from spread-out starts."""
        goal = self._base_placement() * target
        seed_q = np.clip(np.asarray(seed, dtype=float), self.lower, self.upper)
        solution = self._solve(goal, seed_q, tolerance)
        if solution is not None:
            return self._nearest_turn(solution, seed_q)
        rng = np.random.default_rng(0)  # the same answer for the same question
        found: list[FloatArray] = []
        for _ in range(restarts):
            start = rng.uniform(np.maximum(self.lower, -np.pi), np.minimum(self.upper, np.pi))
            solution = self._solve(goal, start, tolerance)
            if solution is not None:
                found.append(self._nearest_turn(solution, seed_q))
                if len(found) == 3:
                    break
        if not found:
            raise Unreachable(
                "no joint position reaches that pose within the joint limits",
                words=words("motion.unreachable"),
            )
        return min(found, key=lambda q: float(np.sum((q - seed_q) ** 2)))

    def solutions(
        self, target: pin.SE3, seed: FloatArray | list[float], starts: int = 30
    ) -> list[FloatArray]:
        """The distinct joint positions (elbow up or down, wrist flipped, …) that put the TCP
        at `target`, nearest the seed first: for a caller who must pick one that is free of
        collisions, which the nearest may not be."""
        goal = self._base_placement() * target
        seed_q = np.clip(np.asarray(seed, dtype=float), self.lower, self.upper)
        rng = np.random.default_rng(0)  # the same answer for the same question
        found: list[FloatArray] = []
        for attempt in range(starts + 1):
            start = (
                seed_q
                if attempt == 0
                else rng.uniform(np.maximum(self.lower, -np.pi), np.minimum(self.upper, np.pi))
            )
            solution = self._solve(goal, start, 1e-10)
            if solution is None:
                continue
            solution = self._nearest_turn(solution, seed_q)
            if not any(np.allclose(solution, q, atol=1e-3) for q in found):
                found.append(solution)
        return sorted(found, key=lambda q: float(np.sum((q - seed_q) ** 2)))

    def _solve(
        self, goal: pin.SE3, start: FloatArray, tolerance: float, max_iterations: int = 100
    ) -> FloatArray | None:
        """Levenberg-Marquardt on the SE(3) log error, clamped to the joint limits."""
        q_model = self._q.copy()
        q = start.copy()
        damping = 1e-3
        previous = np.inf
        for _ in range(max_iterations):
            q_model[self._order] = q
            # One pass gives the joint placements and Jacobians; the TCP follows from them.
            pin.computeJointJacobians(self.model, self.data, q_model)
            motion = pin.updateFramePlacement(self.model, self.data, self._tcp).actInv(goal)
            jacobian = pin.getFrameJacobian(
                self.model, self.data, self._tcp, pin.ReferenceFrame.LOCAL
            )[:, self._order]
            error = pin.log6(motion).vector
            norm = float(error @ error)
            if norm < tolerance**2:
                return q
            # Damping shrinks while the error falls and grows when a step makes it worse.
            damping = max(damping * (0.3 if norm < previous else 3.0), 1e-12)
            previous = norm
            jac = pin.Jlog6(motion.inverse()) @ jacobian
            regular = (damping * norm + 1e-12) * np.eye(6)
            step = jac.T @ np.linalg.solve(jac @ jac.T + regular, error)
            # A joint at a limit that the step pushes further out drops out of it, so the
            # others do the work instead of the step stalling against the clamp.
            held = ((q <= self.lower) & (step < 0)) | ((q >= self.upper) & (step > 0))
            if held.any():
                jac[:, held] = 0.0
                step = jac.T @ np.linalg.solve(jac @ jac.T + regular, error)
            q = np.clip(q + step, self.lower, self.upper)
        return None

    def _nearest_turn(self, q: FloatArray, seed: FloatArray) -> FloatArray:
        """Joints that can turn more than once round: the turn nearest the seed."""
        turns = np.round((seed - q) / (2 * np.pi))
        shifted = q + 2 * np.pi * turns
        inside = (shifted >= self.lower) & (shifted <= self.upper)
        return np.where(inside, shifted, q)

    def _base_placement(self) -> pin.SE3:
        pin.framesForwardKinematics(self.model, self.data, self._q)
        return self.data.oMf[self._base].copy()
