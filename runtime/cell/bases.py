"""Where each robot stands: its base pose in the world is the frame variable
`frames.<robot>` (the identity until calibration or the Scene panel stores one)."""

from __future__ import annotations

import pinocchio as pin

from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.robotics.kinematics import pose_to_se3
from openpendant.runtime.variable_storage.client import StorageClient


def frame_variable(robot: str) -> str:
    return f"frames.{robot}"


async def base_in_world(storage: StorageClient, robot: str) -> pin.SE3:
    try:
        frame = await storage.get(frame_variable(robot))
    except NotFound:
        return pin.SE3.Identity()
    if frame.type != "frame":
        raise InvalidValue(f"{frame_variable(robot)} should be a frame, not a {frame.type}")
    return pose_to_se3(Pose.model_validate(frame.value["pose"]))
