"""A robot-origin calibration run: under the caller's control lease, the robot visits each
pose (planned and collision-checked by the motion service), the camera looks for the flange
tag once the arm is still, and the base's pose in the world is solved from what was seen.
A cancelled run stops the robot; nothing is stored until the user saves the result."""

from __future__ import annotations

import asyncio
import contextlib
import time

import numpy as np
import pinocchio as pin

from openpendant.runtime.cell.bases import base_in_world
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.imaging.markers import find_markers
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.variables import JointWaypoint
from openpendant.runtime.kit.errors import Conflict, OpenPendantError
from openpendant.runtime.motion.client import MotionClient, MoveKind, MoveRequest, MoveState, Target
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.runtime.vision.calibrations import Calibrations
from openpendant.runtime.vision.extrinsics import camera_matrix
from openpendant.runtime.vision.models import OriginPose, RobotOriginRequest, RobotOriginResult
from openpendant.runtime.vision.operations import Operation
from openpendant.runtime.vision.poses import flange_poses
from openpendant.runtime.vision.robot_origin import Camera, Sighting, solve_origin
from openpendant.runtime.vision.transforms import pose_of

SETTLED = 1e-3  # rad/s: every joint slower than this, the arm is still
SETTLE_TIMEOUT = 5.0  # s
MOVE_TIMEOUT = 60.0  # s for one move
MAX_CANDIDATES = 4  # joint solutions of one pose tried before it is left out


class OriginRun:
    def __init__(
        self,
        devices: Devices,
        storage: StorageClient,
        motion: MotionClient,
        calibrations: Calibrations,
    ) -> None:
        self.devices, self.storage, self.motion = devices, storage, motion
        self.calibrations = calibrations

    async def prepare(self, request: RobotOriginRequest, token: str | None) -> Camera:
        """Everything checked before the robot moves: the lease, the camera's calibrations."""
        await self.devices.check_lease(request.robot, token)
        intrinsics = (await self.calibrations.calibration(request.camera)).intrinsics
        placed = await self.calibrations.camera_pose(request.camera)
        if placed is None:
            raise Conflict(
                f"{request.camera} is not placed in the world yet: calibrate its pose first",
                code="camera_not_placed",
            )
        await self.devices.entry(request.camera, "camera")
        return Camera(
            camera_matrix(intrinsics), np.array(intrinsics.distortion, dtype=float), placed
        )

    async def run(
        self, op: Operation, request: RobotOriginRequest, token: str, camera: Camera
    ) -> RobotOriginResult:
        try:
            return await self._run(op, request, token, camera)
        except BaseException:
            # Cancelled or failed: the arm stops where it is.
            with contextlib.suppress(Exception):
                await asyncio.shield(self.motion.stop(request.robot, caller=op.id))
            raise

    async def _run(
        self, op: Operation, request: RobotOriginRequest, token: str, camera: Camera
    ) -> RobotOriginResult:
        robot = await self.devices.robot(request.robot)
        # The flange's kinematics: the robot's with no tool on it.
        info = robot.info.model_copy(update={"tcp": Pose()})
        kinematics = Kinematics(info)
        previous = await base_in_world(self.storage, request.robot)
        goals = await self._goals(
            request, kinematics, previous, camera, robot.current().joint_position
        )
        poses: list[OriginPose] = []
        sightings: list[Sighting] = []
        used: list[int] = []
        for index, goal in enumerate(goals):
            op.report(0.85 * index / len(goals), f"pose {index + 1} of {len(goals)}")
            pose = OriginPose(index=index)
            poses.append(pose)
            if isinstance(goal, str):
                pose.reason = goal
                continue
            pose.joints = [float(v) for v in goal]
            moved = await self._move(request, token, op.id, goal)
            if moved:
                pose.reason = moved
                continue
            joints = await self._still(request.robot)
            gray, _ = await self.calibrations.grab(request.camera)
            corners = (await asyncio.to_thread(find_markers, gray, request.tag.dictionary)).get(
                request.tag.id
            )
            if corners is None:
                pose.reason = f"tag {request.tag.id} not seen"
                continue
            pose.seen = True
            sightings.append(Sighting(kinematics.flange(joints).homogeneous, corners))
            used.append(index)
        op.report(0.85, "solving")
        solution = await asyncio.to_thread(
            solve_origin, sightings, request.tag.size, camera, lambda _p, _s: None
        )
        for k, index in enumerate(used):
            poses[index].residual_px = round(solution.residuals_px[k], 4)
            poses[index].residual_mm = round(solution.residuals_mm[k], 3)
            poses[index].outlier = k in solution.outliers
        before = previous.homogeneous
        turned = pin.log3(solution.base[:3, :3] @ before[:3, :3].T)
        return RobotOriginResult(
            robot=request.robot,
            camera=request.camera,
            base=pose_of(solution.base),
            previous=pose_of(before),
            moved_mm=float(np.linalg.norm(solution.base[:3, 3] - before[:3, 3]) * 1000),
            moved_deg=float(np.degrees(np.linalg.norm(turned))),
            tag_on_flange=pose_of(solution.tag),
            rms_px=round(solution.rms_px, 4),
            poses=poses,
        )

    async def _goals(
        self,
        request: RobotOriginRequest,
        kinematics: Kinematics,
        base: pin.SE3,
        camera: Camera,
        start: list[float],
    ) -> list[np.ndarray | str]:
        """Joint goals, one per pose (or why a pose cannot be reached)."""
        goals: list[np.ndarray | str] = []
        if request.waypoints is not None:
            for name in request.waypoints:
                stored = await self.storage.get(name)
                if stored.type != "joint_waypoint":
                    goals.append(f"{name} is a {stored.type}, not a joint waypoint")
                    continue
                goals.append(np.array(JointWaypoint.model_validate(stored.value).joints))
            return goals
        camera_in_base = (base.inverse().homogeneous @ camera.pose)[:3, 3]
        previous = np.array(start, dtype=float)
        # Each pose's joints the nearest to the last pose's: the arm stays on one branch
        # (elbow, wrist) and travels little between poses, visited in order of nearness.
        for flange in _in_visiting_order(
            flange_poses(request.region, camera_in_base, request.poses)
        ):
            goal = await self._reachable(request.robot, kinematics, flange, previous)
            goals.append(goal)
            if not isinstance(goal, str):
                previous = goal
        return goals

    async def _reachable(
        self, robot: str, kinematics: Kinematics, flange: np.ndarray, start: np.ndarray
    ) -> np.ndarray | str:
        """Of the joint positions that reach the flange pose, the nearest to the start the
        motion service finds a collision-free move to (or why there is none)."""
        candidates = await asyncio.to_thread(kinematics.solutions, pin.SE3(flange), start)
        if not candidates:
            return "out of the robot's reach"
        why = ""
        for joints in candidates[:MAX_CANDIDATES]:
            move = MoveRequest(kind=MoveKind.joint, target=Target(joints=joints.tolist()))
            report = await self.motion.plan(robot, move)
            if report.ok:
                return joints
            why = why or report.message or report.code
        return why

    async def _move(
        self, request: RobotOriginRequest, token: str, caller: str, joints: np.ndarray
    ) -> str:
        """Moves to the joints; returns why not, or "" once there."""
        move = MoveRequest(
            kind=MoveKind.joint,
            target=Target(joints=[float(v) for v in joints]),
            speed=request.speed,
        )
        try:
            status = await self.motion.start(request.robot, move, token, caller)
        except OpenPendantError as exc:
            if exc.status in (409, 422):  # refused: blocked, out of limits
                return exc.message
            raise
        deadline = time.monotonic() + MOVE_TIMEOUT
        while status.state in (MoveState.planning, MoveState.running, MoveState.paused):
            if time.monotonic() > deadline:
                raise Conflict(f"the move to a pose took over {MOVE_TIMEOUT:.0f} s")
            status = await self.motion.status(status.id, wait=5.0)
        if status.state is MoveState.finished:
            return ""
        if status.state is MoveState.failed and status.code in ("blocked", "unreachable"):
            return status.message or status.code
        raise Conflict(f"the move to a pose {status.state}: {status.message}", code="move_failed")

    async def _still(self, robot: str) -> np.ndarray:
        client = await self.devices.robot(robot)
        deadline = time.monotonic() + SETTLE_TIMEOUT
        while True:
            state = client.current()
            if max(abs(v) for v in state.joint_velocity) < SETTLED:
                return np.array(state.joint_position)
            if time.monotonic() > deadline:
                raise Conflict(f"{robot} did not come to rest", code="not_settled")
            await asyncio.sleep(0.02)


def _in_visiting_order(poses: list[np.ndarray]) -> list[np.ndarray]:
    """From the first, each time the nearest pose not visited yet."""
    left = list(poses)
    ordered = [left.pop(0)] if left else []
    while left:
        here = ordered[-1][:3, 3]
        nearest = min(range(len(left)), key=lambda i: float(np.linalg.norm(left[i][:3, 3] - here)))
        ordered.append(left.pop(nearest))
    return ordered
