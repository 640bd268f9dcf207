"""Collision shapes (python-fcl) with what the fast paths need: a bounding sphere for cheap
rejection of far pairs, and a description the 3D view can draw."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import fcl
import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.meshes import convex_hull

Faces = list[tuple[int, int, int]]


@dataclass
class Shape:
    """One collision body: geometry, where it sits on its parent (a link frame, the world,
    or a TCP), and its placement in the world after the last update."""

    name: str
    geometry: Any  # an fcl geometry
    local: pin.SE3
    radius: float  # bounding sphere about `center` (in the shape's own frame)
    center: FloatArray
    drawing: dict[str, Any]
    kind: str = "hull"  # box, cylinder, sphere or hull
    size: tuple[float, ...] = ()  # box edges; cylinder radius and length; sphere radius
    hull: tuple[FloatArray, Faces] | None = None  # vertices and faces, for a hull
    obj: fcl.CollisionObject = field(init=False)
    world_center: FloatArray = field(init=False)
    rotation: FloatArray = field(init=False)  # of the shape in the world
    translation: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        self.obj = fcl.CollisionObject(self.geometry, fcl.Transform())
        self.world_center = self.center.copy()
        self.rotation, self.translation = np.eye(3), np.zeros(3)
        self.placements = 0  # how often it was placed: what is worked out from a placement
        self._synced = True  # can tell whether it still holds

    def place(self, parent: pin.SE3) -> None:
        world = parent * self.local
        self.rotation, self.translation = world.rotation, world.translation
        self.world_center = world.act(self.center)
        self.placements += 1
        # Handing a placement to FCL costs more than the rest of placing a shape: it is done
        # when a distance query needs it, and most pairs are settled by their bounds.
        self._synced = False

    def sync(self) -> None:
        """The FCL object at the last placement."""
        if not self._synced:
            self.obj.setTransform(fcl.Transform(self.rotation, self.translation))
            self._synced = True


def box(name: str, size: list[float], local: pin.SE3) -> Shape:
    half = np.asarray(size) / 2
    drawing = {"shape": "box", "size": list(size)}
    radius = float(np.linalg.norm(half))
    return Shape(
        name, fcl.Box(*size), local, radius, np.zeros(3), drawing, "box", tuple(map(float, size))
    )


def cylinder(name: str, radius: float, length: float, local: pin.SE3) -> Shape:
    bound = float(np.hypot(radius, length / 2))
    drawing = {"shape": "cylinder", "size": [radius, length]}
    geometry = fcl.Cylinder(radius, length)
    return Shape(name, geometry, local, bound, np.zeros(3), drawing, "cylinder", (radius, length))


def sphere(name: str, radius: float, local: pin.SE3) -> Shape:
    drawing = {"shape": "sphere", "size": [radius]}
    return Shape(name, fcl.Sphere(radius), local, radius, np.zeros(3), drawing, "sphere", (radius,))


def mesh(name: str, path: Path, scale: tuple[float, float, float], local: pin.SE3) -> Shape:
    vertices, faces = convex_hull(path, scale)
    flat = np.array([[3, *f] for f in faces], dtype=np.int64).ravel()
    geometry = fcl.Convex(vertices, len(faces), flat)
    center = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    radius = float(np.max(np.linalg.norm(vertices - center, axis=1)))
    drawing = {"shape": "hull", "vertices": vertices.round(5).tolist(), "faces": faces}
    return Shape(name, geometry, local, radius, center, drawing, hull=(vertices, faces))


@dataclass
class BodyPart:
    """A shape of a robot's body, and where it is fixed on the robot."""

    shape: Shape
    frame: int  # model frame the shape is fixed to
    joint: int  # model joint that moves it (0: fixed to the base)


@dataclass(frozen=True)
class Proximity:
    """The nearest points of two bodies (world frame) and their signed distance."""

    distance: float
    body: str
    other: str
    point: FloatArray  # on `body`
    other_point: FloatArray


_REQUEST = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)


def proximity(a: Shape, b: Shape) -> Proximity:
    a.sync()
    b.sync()
    result = fcl.DistanceResult()
    distance = fcl.distance(a.obj, b.obj, _REQUEST, result)
    p, q = result.nearest_points
    return Proximity(float(distance), a.name, b.name, np.array(p), np.array(q))


def sphere_gap(a: Shape, b: Shape) -> float:
    """A lower bound of the distance between two shapes, from their bounding spheres."""
    return float(np.linalg.norm(a.world_center - b.world_center)) - a.radius - b.radius
