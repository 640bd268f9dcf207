"""Parts on a table, in a simulated robot's base frame. A gripper closing grasps the nearest
free part within reach of the TCP (if it fits between the fingers); the part then moves
with the TCP until the gripper opens, when it falls onto the table where it is. Presence
sensors see whether a part lies within their radius.

True poses are what tests check a pick and place by (`GET /sim/cell/parts` on the robot)."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import numpy as np
import pinocchio as pin
from pydantic import Field

from runtime.interfaces.common import Pose, Strict
from runtime.robotics.kinematics import pose_to_se3, se3_to_pose

REACH = 0.03  # m from the TCP to a part's centre for the fingers to close on it
TABLE_Z = 0.0  # the table top, in the base frame (the robot stands on it)


class Part(Strict):
    id: str = Field(pattern=r"^[A-Za-z0-9_-]{1,32}$")
    size: list[float] = Field(min_length=3, max_length=3)  # m: x, y (across the fingers), z
    pose: Pose
    held: bool = False


class Sensor(Strict):
    position: list[float] = Field(min_length=3, max_length=3)  # m, base frame
    radius: float = Field(default=0.03, gt=0, le=1)


class CellSetup(Strict):
    parts: list[Part] = Field(default_factory=list, max_length=200)
    sensors: dict[str, Sensor] = Field(default_factory=dict)


def default_world() -> CellSetup:
    """Three 40 mm cubes in front of a UR5; `part_present` watches the first one's place."""
    cubes = [
        Part(id=f"part{i + 1}", size=[0.04, 0.04, 0.04], pose=Pose(position=[0.45, y, 0.02]))
        for i, y in enumerate((-0.2, 0.0, 0.2))
    ]
    return CellSetup(parts=cubes, sensors={"part_present": Sensor(position=[0.45, -0.2, 0.02])})


class World:
    def __init__(self, tcp: Callable[[], Pose], setup: CellSetup | None = None) -> None:
        self.tcp = tcp  # the robot's TCP pose now, in its base frame
        self.lock = threading.Lock()
        self.parts: dict[str, Part] = {}
        self.sensors: dict[str, Sensor] = {}
        self._held: str | None = None
        self._grip = pin.SE3.Identity()  # the held part in the TCP frame
        self.replace(setup or default_world())

    def replace(self, setup: CellSetup) -> None:
        with self.lock:
            self.parts = {p.id: p.model_copy(update={"held": False}) for p in setup.parts}
            self.sensors = dict(setup.sensors)
            self._held = None

    def _pose_of(self, part: Part) -> Pose:
        if part.id == self._held:
            return se3_to_pose(pose_to_se3(self.tcp()) * self._grip)
        return part.pose

    def snapshot(self) -> list[Part]:
        with self.lock:
            return [
                p.model_copy(update={"pose": self._pose_of(p), "held": p.id == self._held})
                for p in self.parts.values()
            ]

    def grasp(self, opening: float) -> Part | None:
        """The fingers close: the nearest free part within reach that fits between them."""
        with self.lock:
            if self._held is not None:
                return self.parts[self._held]
            tcp = pose_to_se3(self.tcp())
            found: tuple[float, Part] | None = None
            for part in self.parts.values():
                gap = float(np.linalg.norm(np.array(part.pose.position) - tcp.translation))
                if gap <= REACH and part.size[1] <= opening and (found is None or gap < found[0]):
                    found = (gap, part)
            if found is None:
                return None
            part = found[1]
            self._held = part.id
            self._grip = tcp.inverse() * pose_to_se3(part.pose)
            return part

    def release(self) -> Part | None:
        """The fingers open: a held part falls upright onto the table below it."""
        with self.lock:
            if self._held is None:
                return None
            part = self.parts[self._held]
            where = pose_to_se3(self.tcp()) * self._grip
            yaw = math.atan2(where.rotation[1, 0], where.rotation[0, 0])
            x, y, _ = where.translation
            fallen = pin.SE3(
                pin.rpy.rpyToMatrix(0.0, 0.0, yaw), np.array([x, y, TABLE_Z + part.size[2] / 2])
            )
            part = part.model_copy(update={"pose": se3_to_pose(fallen)})
            self.parts[part.id] = part
            self._held = None
            return part

    def sensed(self) -> dict[str, bool]:
        """Each presence sensor: is a part (not one in the gripper) within its radius."""
        with self.lock:
            found = {}
            for name, sensor in self.sensors.items():
                at = np.array(sensor.position)
                found[name] = any(
                    p.id != self._held
                    and float(np.linalg.norm(np.array(p.pose.position) - at)) <= sensor.radius
                    for p in self.parts.values()
                )
            return found
