"""The world: every robot's bodies at its base pose, and the scene's obstacles and keep-out
zones. Answers "how close is this robot, at these joints, to anything else?"."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import RobotInfo
from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.paths import resolve_package_uri
from openpendant.runtime.robotics import geometry
from openpendant.runtime.robotics.broadphase import FixedShapes, sphere_gaps
from openpendant.runtime.robotics.geometry import BodyPart, Proximity, Shape, proximity
from openpendant.runtime.robotics.kinematics import Kinematics, pose_to_se3
from openpendant.runtime.robotics.robot_body import RobotBody

IntArray = npt.NDArray[np.intp]

# Self pairs whose bounding spheres come this near get their exact distance (m): elsewhere the
# spheres' gap is a good enough lower bound.
NEAR_SELF = 0.05


def scene_shape(name: str, obj: SceneObject) -> Shape:
    """The collision shape of a scene object, `local` being its pose (world or TCP frame)."""
    local = pose_to_se3(obj.pose)
    if obj.shape == "box":
        return geometry.box(name, obj.size, local)
    if obj.shape == "cylinder":
        return geometry.cylinder(name, obj.size[0], obj.size[1], local)
    if obj.shape == "sphere":
        return geometry.sphere(name, obj.size[0], local)
    path = resolve_package_uri(obj.mesh or "")
    return geometry.mesh(name, path, (obj.size[0], obj.size[1], obj.size[2]), local)


def build_obstacles(objects: dict[str, SceneObject]) -> list[Shape]:
    """The placed shapes of the objects standing in the world (mesh hulls take a while:
    this touches no world, so it can run on another thread)."""
    obstacles = []
    for name, obj in sorted(objects.items()):
        if obj.attached_to is None:
            shape = scene_shape(name, obj)
            shape.place(pin.SE3.Identity())
            obstacles.append(shape)
    return obstacles


@dataclass
class Contact:
    """What a robot part is nearest to (or touching, at distance ≤ 0)."""

    part: BodyPart
    proximity: Proximity


class World:
    def __init__(self) -> None:
        self.robots: dict[str, RobotBody] = {}
        self.objects: dict[str, SceneObject] = {}
        self.obstacles: list[Shape] = []
        self._fixed = FixedShapes([])

    # Contents -------------------------------------------------------------------------------

    def add_robot(
        self, name: str, info: RobotInfo, base: pin.SE3 | None = None, urdf: Path | None = None
    ) -> RobotBody:
        body = RobotBody(name, Kinematics(info, urdf), urdf)
        body.set_base(base or pin.SE3.Identity())
        self.insert_robot(body)
        return body

    def insert_robot(self, body: RobotBody) -> None:
        """A robot body built elsewhere (off the event loop), replacing one of its name."""
        self.robots = {**self.robots, body.name: body}
        self._attach()

    def remove_robot(self, name: str) -> None:
        self.robots = {k: v for k, v in self.robots.items() if k != name}

    def robot(self, name: str) -> RobotBody:
        body = self.robots.get(name)
        if body is None:
            raise NotFound(f"robot {name!r} is not in the scene", code="unknown_robot")
        return body

    def set_objects(
        self, objects: dict[str, SceneObject], obstacles: list[Shape] | None = None
    ) -> None:
        """Replace the scene's objects (obstacles, keep-out zones, carried objects); the
        obstacles' shapes may come ready-made from `build_obstacles`."""
        if obstacles is None:
            obstacles = build_obstacles(objects)
        self.objects, self.obstacles = dict(objects), obstacles
        self._attach()

    def _attach(self) -> None:
        for robot_name, body in self.robots.items():
            body.carry(
                [
                    scene_shape(name, obj)
                    for name, obj in sorted(self.objects.items())
                    if obj.attached_to == robot_name
                ]
            )

    # Queries ----------------------------------------------------------------------------------

    def _others(self, robot: str) -> list[Shape]:
        shapes = list(self.obstacles)
        for name, body in self.robots.items():
            if name != robot:
                shapes.extend(body.shapes)
        return shapes

    def contacts(
        self, robot: str, q: FloatArray | None = None, within: float = np.inf
    ) -> list[Contact]:
        """Every (moving part, other body) pair of `robot` closer than `within`, nearest
        points included; the robot is placed at `q` first when given."""
        parts, others, gaps = self._pairs(robot, q)
        found = []
        for i, j in zip(*np.nonzero(gaps < within), strict=True):
            near = proximity(parts[i].shape, others[j])
            if near.distance < within:
                found.append(Contact(parts[i], near))
        return found

    def nearest(self, robot: str, q: FloatArray | None = None) -> Contact | None:
        """The closest pair of the robot's moving parts and anything else."""
        parts, others, gaps = self._pairs(robot, q)
        best: Contact | None = None
        # Pairs in order of their lower bound; stop once no remaining pair can be nearer.
        for flat in np.argsort(gaps, axis=None):
            i, j = np.unravel_index(flat, gaps.shape)
            if best is not None and gaps[i, j] >= best.proximity.distance:
                break
            near = proximity(parts[i].shape, others[j])
            if best is None or near.distance < best.proximity.distance:
                best = Contact(parts[i], near)
        return best

    def part_clearances(
        self,
        robot: str,
        q: FloatArray | None = None,
        within: float = np.inf,
        which: IntArray | None = None,
    ) -> FloatArray:
        """For each of the robot's moving parts (or those indexed by `which`), placed at `q`
        when given: a lower bound of its distance to anything else, exact when that is under
        `within`, else at least `within`."""
        parts, others, gaps = self._pairs(robot, q, which)
        if not others:
            return np.full(len(parts), np.inf)
        clear: FloatArray = gaps.min(axis=1)
        for i in np.nonzero(clear < within)[0]:
            # Exact distances in the order of their bounds, until no other can be nearer.
            best = np.inf
            for j in np.argsort(gaps[i]):
                if gaps[i, j] >= min(best, within):
                    best = min(best, gaps[i, j])
                    break
                best = min(best, proximity(parts[i].shape, others[j]).distance)
            clear[i] = best
        return clear

    def self_clearances(
        self, robot: str, which: IntArray | None = None
    ) -> tuple[Contact | None, FloatArray]:
        """At the robot's current placement: the distance of each of its self pairs (or of
        those indexed by `which`): exact where their bounding spheres come within NEAR_SELF,
        else the spheres' gap, a lower bound; and the pair in contact, if any."""
        pairs = self.robot(robot).self_pairs
        if which is not None:
            pairs = [pairs[i] for i in which]
        if not pairs:
            return None, np.zeros(0)
        a = np.array([x.shape.world_center for x, _ in pairs])
        b = np.array([y.shape.world_center for _, y in pairs])
        radii = np.array([x.shape.radius + y.shape.radius for x, y in pairs])
        distances: FloatArray = np.linalg.norm(a - b, axis=1) - radii
        touching: Contact | None = None
        for i in np.nonzero(distances < NEAR_SELF)[0]:
            x, y = pairs[i]
            near = proximity(x.shape, y.shape)
            distances[i] = near.distance
            if near.distance <= 0 and (
                touching is None or near.distance < touching.proximity.distance
            ):
                touching = Contact(x, near)
        return touching, distances

    def _pairs(
        self, robot: str, q: FloatArray | None, which: IntArray | None = None
    ) -> tuple[list[BodyPart], list[Shape], FloatArray]:
        """The robot's moving parts (those indexed by `which`, placed at `q` when given),
        every other body, and the lower bound of each pair's distance."""
        body = self.robot(robot)
        if q is not None:
            body.place(q)
        parts = body.moving
        if which is not None:
            parts = [parts[i] for i in which]
        others = self._others(robot)  # obstacles first
        if not parts or not others:
            return parts, others, np.zeros((len(parts), len(others)))
        return parts, others, self._lower_bounds(parts, others[len(self.obstacles) :])

    def _lower_bounds(self, parts: list[BodyPart], robots: list[Shape]) -> FloatArray:
        """Lower bounds of the distance of each part to each obstacle, then to each of
        the other robots' shapes (the columns of `_pairs`)."""
        if not self._fixed.current(self.obstacles):
            self._fixed = FixedShapes(self.obstacles)
        centers = np.array([p.shape.world_center for p in parts])
        radii = np.array([p.shape.radius for p in parts])
        gaps = self._fixed.lower_bounds(centers, radii)
        if robots:
            others = np.array([s.world_center for s in robots])
            gaps = np.hstack(
                (gaps, sphere_gaps(centers, radii, others, np.array([s.radius for s in robots])))
            )
        return gaps
