"""A quick collision screen for the planner's search: the robot's parts and everything around
it as a pinocchio collision model (coal, in C++, where the rest of the world's queries are
python-fcl called from Python), asked only whether any pair comes within its margin, for many
configurations in one call. Its answer is never trusted with a path: what the planner returns
is proven by the conservative PathChecker, which reads the same shapes.

Each pair's margin is the check's (the move's margin for the scene, none between the robot's
own links) plus a pad that keeps searched paths off the surfaces they would otherwise graze,
so the path check that follows finds room at once. A pair already near at the start or the
goal gets less pad: half what it has there."""

from __future__ import annotations

from functools import lru_cache

import coal
import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.geometry import Shape
from openpendant.runtime.robotics.world import World

PAD = 0.01  # m


# Hulls made once per mesh file (the vertex arrays are themselves made once per file and kept).
_HULLS: dict[int, tuple[FloatArray, coal.Convex]] = {}


def _geometry(shape: Shape) -> coal.CollisionGeometry:
    if shape.kind == "box":
        return coal.Box(*shape.size)
    if shape.kind == "cylinder":
        return coal.Cylinder(*shape.size)
    if shape.kind == "sphere":
        return coal.Sphere(*shape.size)
    assert shape.hull is not None
    vertices, faces = shape.hull
    made = _HULLS.get(id(vertices))
    if made is None or made[0] is not vertices:
        points = coal.StdVec_Vec3s()
        points.extend(vertices)
        triangles = coal.StdVec_Triangle()
        triangles.extend(coal.Triangle(*face) for face in faces)
        made = (vertices, coal.Convex(points, triangles))
        _HULLS[id(vertices)] = made
    return made[1]


class Screen:
    """Whether configurations of one robot keep every pair of its parts and the rest of the
    world apart by its margin; the world as it stands now (later changes are not seen)."""

    def __init__(
        self,
        world: World,
        robot: str,
        margin: float,
        ends: list[FloatArray],
        resolution: float,
        pad: float = PAD,
    ) -> None:
        body = world.robot(robot)
        self.model = model = body.model
        self.data = model.createData()
        self.order = body.kinematics.order
        self.neutral = pin.neutral(model)
        self.bounds = body.reach_bounds()
        self.resolution = resolution
        self.checks = 0
        geometry = pin.GeometryModel()
        index: dict[str, int] = {}
        for part in (*body.parts, *body.carried):
            local = model.frames[part.frame].placement * part.shape.local
            name = part.shape.name
            obj = pin.GeometryObject(name, part.joint, part.frame, local, _geometry(part.shape))
            index[name] = geometry.addGeometryObject(obj)
        # Everything else stays where it is, in the model's root frame.
        root = body.world_base * body.data.oMf[body.kinematics.base_frame].inverse()
        others = list(world.obstacles)
        for name, other in world.robots.items():
            if name != robot:
                others.extend(other.shapes)
        for shape in others:
            placement = root.actInv(pin.SE3(shape.rotation, shape.translation))
            obj = pin.GeometryObject(shape.name, 0, 0, placement, _geometry(shape))
            index[shape.name] = geometry.addGeometryObject(obj)
        base: list[float] = []
        pairs = [(part.shape, shape, margin) for part in body.moving for shape in others]
        pairs += [(a.shape, b.shape, 0.0) for a, b in body.self_pairs]
        for a_shape, b_shape, kept in pairs:
            geometry.addCollisionPair(pin.CollisionPair(index[a_shape.name], index[b_shape.name]))
            base.append(kept)
        self.geometry = geometry
        self.geometry_data = pin.GeometryData(geometry)
        # The pads: from each pair's distance at the ends of the move.
        near = np.full(len(base), np.inf)
        for q in ends:
            pin.computeDistances(model, self.data, geometry, self.geometry_data, self._full(q))
            near = np.minimum(near, [r.min_distance for r in self.geometry_data.distanceResults])
        self.margins = np.asarray(base) + np.clip((near - base) / 2, 0.0, pad)
        self.pool = pin.GeometryPool(model, geometry, 1)
        for data in (self.geometry_data, self.pool.getGeometryData(0)):
            for k, request in enumerate(data.collisionRequests):
                request.security_margin = float(self.margins[k])
                request.num_max_contacts = 1

    def _full(self, q: FloatArray) -> FloatArray:
        full: FloatArray = self.neutral.copy()
        full[self.order] = q
        return full

    def clear(self, q: FloatArray) -> bool:
        self.checks += 1
        full = self._full(q)
        return not pin.computeCollisions(
            self.model, self.data, self.geometry, self.geometry_data, full, True
        )

    def motion(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether the straight joint line from `a` (clear) to `b` is: configurations
        `resolution` of any body point's travel apart, the middle ones first."""
        steps = max(1, int(np.ceil(float(self.bounds @ np.abs(b - a)) / self.resolution)))
        fractions = _bisection(steps)
        self.checks += steps
        batch = np.repeat(self.neutral[:, None], steps, axis=1)
        batch[self.order, :] = a[:, None] + (b - a)[:, None] * fractions[None, :]
        hits = pin.computeCollisionsInParallel(1, self.pool, np.asfortranarray(batch), True, True)
        return not bool(np.any(hits))


@lru_cache(maxsize=512)
def _bisection(steps: int) -> FloatArray:
    """The fractions k/steps for k = 1 … steps: the end first, then halves, quarters, …
    (a collision is found sooner than from one end). Read only."""
    picked, seen, span = [steps], {0, steps}, steps
    while len(picked) < steps:
        span = max(1, span // 2)
        for k in range(span, steps, span):
            if k not in seen:
                seen.add(k)
                picked.append(k)
    return np.array(picked, dtype=float) / steps
