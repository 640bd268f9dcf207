"""Parts on a table around a simulated robot. A gripper closing grasps the nearest free part
within reach of the TCP (if it fits between the fingers); the part then moves with the TCP
until the gripper opens, when it falls onto the table where it is. Presence sensors see
whether a part lies within their radius. A part may carry an ArUco tag on its top face, and
the robot one on its flange, for the simulated camera to see.

The robot truly stands at `base` in the world (the identity unless a test moves it: the
runtime's belief is its `frames.<robot>` variable, which calibration finds). Parts and
sensors stay where they are in the world when the robot is moved; they are laid out and
listed in the robot's base frame (`GET /sim/cell/parts` on the robot: the true poses tests
check a pick and place by), or in the world's."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import pinocchio as pin
from pydantic import Field

from openpendant.runtime.interfaces.common import Pose, Strict
from openpendant.runtime.robotics.kinematics import pose_to_se3, se3_to_pose

REACH = 0.03  # m from the TCP to a part's centre for the fingers to close on it
TABLE_Z = 0.0  # the table top in the world (the robot stands on it until it is moved)


class Part(Strict):
    id: str = Field(pattern=r"^[A-Za-z0-9_-]{1,32}$")
    size: list[float] = Field(min_length=3, max_length=3)  # m: x, y (across the fingers), z
    pose: Pose
    held: bool = False
    tag: int | None = Field(default=None, ge=0, le=999)  # an ArUco id on its top face


class FlangeTag(Strict):
    """An ArUco tag on a plate on the robot's flange, its printed face looking along the
    flange's z (away from the wrist), `offset` out from the flange face."""

    id: int = Field(default=0, ge=0, le=999)
    size: float = Field(default=0.06, gt=0.005, le=0.3)  # the marker's side (m)
    offset: float = Field(default=0.005, ge=0, le=0.3)


class Sensor(Strict):
    position: list[float] = Field(min_length=3, max_length=3)  # m, base frame
    radius: float = Field(default=0.03, gt=0, le=1)


class CellSetup(Strict):
    parts: list[Part] = Field(default_factory=list, max_length=200)
    sensors: dict[str, Sensor] = Field(default_factory=dict)
    flange_tag: FlangeTag | None = None


def tag_on_flange(tag: FlangeTag) -> pin.SE3:
    """The tag's frame (x right, y down its print, z into it) in the flange frame: its print
    faces along the flange's z, so its z is the flange's -z."""
    turned = pin.rpy.rpyToMatrix(math.pi, 0.0, 0.0)
    return pin.SE3(turned, np.array([0.0, 0.0, tag.offset]))


def default_world() -> CellSetup:
    """Three 40 mm cubes in front of a UR5, tagged 1, 2 and 3; `part_present` watches the
    first one's place; tag 0 on the flange."""
    cubes = [
        Part(
            id=f"part{i + 1}",
            size=[0.04, 0.04, 0.04],
            pose=Pose(position=[0.45, y, 0.02]),
            tag=i + 1,
        )
        for i, y in enumerate((-0.2, 0.0, 0.2))
    ]
    return CellSetup(
        parts=cubes,
        sensors={"part_present": Sensor(position=[0.45, -0.2, 0.02])},
        flange_tag=FlangeTag(),
    )


Frame = Literal["base", "world"]


class World:
    def __init__(
        self,
        tcp: Callable[[], Pose],
        setup: CellSetup | None = None,
        flange: Callable[[], Pose] | None = None,
    ) -> None:
        self.tcp = tcp  # the robot's TCP pose now, in its base frame
        self.flange = flange  # its flange's, where the simulator knows it
        self.lock = threading.Lock()
        self.base = pin.SE3.Identity()  # where the robot truly stands in the world
        self.parts: dict[str, Part] = {}  # poses in the world
        self.sensors: dict[str, Sensor] = {}  # positions in the world
        self.flange_tag: FlangeTag | None = None
        self._held: str | None = None
        self._grip = pin.SE3.Identity()  # the held part in the TCP frame
        self.replace(setup or default_world())

    def replace(self, setup: CellSetup, frame: Frame = "base") -> None:
        with self.lock:
            to_world = self.base if frame == "base" else pin.SE3.Identity()
            self.parts = {
                p.id: p.model_copy(
                    update={"held": False, "pose": se3_to_pose(to_world * pose_to_se3(p.pose))}
                )
                for p in setup.parts
            }
            self.sensors = {
                name: sensor.model_copy(
                    update={"position": (to_world.act(np.array(sensor.position))).tolist()}
                )
                for name, sensor in setup.sensors.items()
            }
            self.flange_tag = setup.flange_tag
            self._held = None

    def move_base(self, pose: Pose) -> None:
        """The robot set down elsewhere in the world (a held part goes with its TCP)."""
        with self.lock:
            self.base = pose_to_se3(pose)

    def _tcp(self) -> pin.SE3:
        return self.base * pose_to_se3(self.tcp())

    def _pose_of(self, part: Part) -> pin.SE3:
        if part.id == self._held:
            return self._tcp() * self._grip
        return pose_to_se3(part.pose)

    def snapshot(self, frame: Frame = "base") -> list[Part]:
        with self.lock:
            to_frame = self.base.inverse() if frame == "base" else pin.SE3.Identity()
            return [
                p.model_copy(
                    update={
                        "pose": se3_to_pose(to_frame * self._pose_of(p)),
                        "held": p.id == self._held,
                    }
                )
                for p in self.parts.values()
            ]

    def scene(self) -> dict[str, Any]:
        """What a camera sees, in the world: the parts and the flange's tag."""
        parts = [p.model_dump() for p in self.snapshot("world")]
        with self.lock:
            base, tag = self.base, self.flange_tag
        flange_tag = None
        if tag is not None and self.flange is not None:
            where = base * pose_to_se3(self.flange()) * tag_on_flange(tag)
            flange_tag = {"id": tag.id, "size": tag.size, "pose": se3_to_pose(where).model_dump()}
        return {"base": se3_to_pose(base).model_dump(), "parts": parts, "flange_tag": flange_tag}

    def grasp(self, opening: float) -> Part | None:
        """The fingers close: the nearest free part within reach that fits between them."""
        with self.lock:
            if self._held is not None:
                return self.parts[self._held]
            tcp = self._tcp()
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
            where = self._tcp() * self._grip
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
