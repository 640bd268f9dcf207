"""Teaching waypoints from a robot's current position, and turning a stored waypoint back
into a joint goal. A robot's base pose in the world is the frame variable `frames.<robot>`
(the identity until calibration stores one)."""

from __future__ import annotations

from typing import Any

import numpy as np

from openpendant.runtime.cell.bases import base_in_world
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.interfaces.robot import RobotState
from openpendant.runtime.interfaces.variables import Variable
from openpendant.runtime.jog.models import TeachRequest, Waypoint
from openpendant.runtime.kit.errors import Conflict, InvalidValue
from openpendant.runtime.robotics.kinematics import Kinematics, pose_to_se3, se3_to_pose
from openpendant.runtime.variable_storage.client import StorageClient

WAYPOINT_TYPES = ("joint_waypoint", "pose_waypoint")


async def teach(
    storage: StorageClient,
    robot: str,
    state: RobotState,
    kinematics: Kinematics,
    request: TeachRequest,
) -> Variable:
    q = np.array(state.joint_position)
    if request.kind == "joint":
        type_name = "joint_waypoint"
        value: dict[str, Any] = {"joints": q.tolist(), "robot": robot}
    else:
        type_name = "pose_waypoint"
        pose = kinematics.tcp(q)
        if request.frame == "world":
            pose = (await base_in_world(storage, robot)) * pose
        value = {"pose": se3_to_pose(pose).model_dump(), "frame": request.frame, "robot": robot}
    try:
        return await storage.put(
            request.name,
            type_name,
            value,
            tags=request.tags,
            doc=request.doc,
            expected_version=None if request.overwrite else 0,
        )
    except Conflict as exc:
        if exc.code == "version_conflict":
            raise Conflict(
                f"a variable named {request.name!r} exists; confirm to overwrite it", code="exists"
            ) from exc
        raise


async def joint_goal(
    storage: StorageClient,
    robot: str,
    name: str,
    kinematics: Kinematics,
    checker: JointLimitChecker,
    current: FloatArray,
) -> FloatArray:
    waypoint = await storage.get(name)
    if waypoint.type not in WAYPOINT_TYPES:
        raise InvalidValue(f"{name!r} is a {waypoint.type}, not a waypoint", code="not_a_waypoint")
    owner = waypoint.value.get("robot")
    if owner is not None and owner != robot:
        raise InvalidValue(f"{name!r} was taught on {owner}, not {robot}", code="other_robot")
    if waypoint.type == "joint_waypoint":
        return checker.positions(waypoint.value["joints"], f"waypoint {name}")
    target = pose_to_se3(Pose.model_validate(waypoint.value["pose"]))
    if waypoint.value.get("frame", "base") == "world":
        target = (await base_in_world(storage, robot)).actInv(target)
    elif waypoint.value.get("frame", "base") != "base":
        raise InvalidValue(f"frame {waypoint.value['frame']!r} is not known yet")
    return checker.positions(kinematics.inverse(target, current).tolist(), f"waypoint {name}")


async def robot_waypoints(
    storage: StorageClient, robot: str, kinematics: Kinematics
) -> list[Waypoint]:
    """The waypoints of this robot with their TCP positions in its base frame (for the 3D
    view): joint waypoints through forward kinematics, pose waypoints as stored."""
    world = None
    found = []
    for type_name in WAYPOINT_TYPES:
        for variable in await storage.query(type_name=type_name):
            if variable.value.get("robot") not in (None, robot):
                continue
            if type_name == "joint_waypoint":
                joints = variable.value["joints"]
                if len(joints) != len(kinematics.lower):
                    continue
                position = kinematics.tcp(np.array(joints)).translation
            else:
                pose = pose_to_se3(Pose.model_validate(variable.value["pose"]))
                if variable.value.get("frame") == "world":
                    world = world or await base_in_world(storage, robot)
                    pose = world.actInv(pose)
                position = pose.translation
            found.append(
                Waypoint.model_validate(
                    {
                        "name": variable.name,
                        "type": type_name,
                        "tags": variable.tags,
                        "doc": variable.doc,
                        "updated": variable.updated,
                        "tcp_position": [float(v) for v in position],
                    }
                )
            )
    return sorted(found, key=lambda w: w.name)
