"""The runtime's answers to the vision blocks (runtime/program/calls.py says how they are
written): what a detector found, each pose put into the base frame of the robot the program
commands."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.cell.bases import base_in_world
from openpendant.runtime.interfaces.detector import DetectRequest
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.program.calls import DEVICE_NAME
from openpendant.runtime.program.host import RunHost
from openpendant.runtime.robotics.kinematics import pose_to_se3, se3_to_pose
from openpendant.runtime.vision.client import vision_client
from openpendant.sandbox.supervisor import CallRefused


async def vision_detect(run: RunHost, args: dict[str, Any]) -> list[dict[str, Any]]:
    name = str(args["detector"])
    if not DEVICE_NAME.match(name):
        raise CallRefused(f"{name[:40]!r} is not a detector's name", "unknown_detector")
    try:
        found = await vision_client().detect(name, DetectRequest())
        robot = await run.active_robot()
        base = await base_in_world(run.storage, robot)
    except OpenPendantError as exc:
        raise CallRefused(f"detect with {name}: {exc.message}", exc.code) from None
    to_base = base.inverse()
    return [
        {
            "label": d.label,
            "confidence": d.confidence,
            "pose": None
            if d.world_pose is None
            else se3_to_pose(to_base * pose_to_se3(d.world_pose)).model_dump(),
            "age": found.age,
        }
        for d in found.detections
    ]
