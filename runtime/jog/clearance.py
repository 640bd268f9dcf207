"""Move-to and incremental steps pass the same collision checks as the motion service's
moves (the scene, the other robots, the robot's own links) before anything moves: a held
Move-to must not drive the arm through a box."""

from __future__ import annotations

from runtime.interfaces.limits import FloatArray
from runtime.kit.client import ServiceClient
from runtime.kit.errors import OpenPendantError


class PathRefused(OpenPendantError):
    status = 409
    code = "collision"


class PathCheck:
    def __init__(self, motion: ServiceClient) -> None:
        self.motion = motion

    async def joint_line(self, robot: str, goal: FloatArray) -> None:
        """Raises PathRefused, naming the colliding pair, when the straight joint line from
        where the robot is to `goal` would touch anything."""
        report = await self.motion.post(
            f"/motion/robots/{robot}/plan",
            json={
                "kind": "joint",
                "target": {"joints": [float(v) for v in goal]},
                "avoid_obstacles": False,  # the jog follows this line, or nothing
            },
        )
        if not report.get("ok"):
            collision = report.get("collision")
            raise PathRefused(
                str(report.get("message") or "the path is not clear"),
                code=str(report.get("code") or "collision"),
                details={"collision": collision} if isinstance(collision, dict) else None,
            )
