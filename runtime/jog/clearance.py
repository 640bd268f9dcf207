"""Move-to and incremental steps pass the same collision checks as the motion service's
moves (the scene, the other robots, the robot's own links) before anything moves: a held
Move-to must not drive the arm through a box."""

from __future__ import annotations

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.motion.client import MotionClient, MoveKind, MoveRequest, Target


class PathRefused(OpenPendantError):
    status = 409
    code = "collision"


class PathCheck:
    def __init__(self, motion: MotionClient) -> None:
        self.motion = motion

    async def joint_line(self, robot: str, goal: FloatArray) -> None:
        """Raises PathRefused, naming the colliding pair, when the straight joint line from
        where the robot is to `goal` would touch anything."""
        request = MoveRequest(
            kind=MoveKind.joint,
            target=Target(joints=[float(v) for v in goal]),
            avoid_obstacles=False,  # the jog follows this line, or nothing
        )
        report = await self.motion.plan(robot, request)
        if not report.ok:
            collision = report.collision
            raise PathRefused(
                report.message or "the path is not clear",
                code=report.code or "collision",
                details={"collision": collision.model_dump()} if collision else None,
                words=report.words,
            )
