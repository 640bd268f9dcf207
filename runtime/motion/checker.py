"""Collision checking of a joint path by conservative advancement: at each checked
configuration the clearance d says how far any body point may travel before it could touch
something, and the next check comes before that (or after `resolution` of travel when d is
smaller), so no body can pass through anything thicker than twice `resolution` unseen.
The robot's own links are checked against each other too; both may move toward each other,
so their clearance counts half."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime.interfaces.limits import FloatArray
from runtime.motion.world import Contact, World

RESOLUTION = 0.004  # m of travel of any body point between checks, at worst


@dataclass(frozen=True)
class Collision:
    robot_part: str
    other: str
    distance: float
    position: list[float]  # joint positions where it happens
    point: list[float]  # world point on the robot part
    index: int  # path sample at or after which it happens

    def describe(self) -> str:
        return f"{self.robot_part} would hit {self.other}"


def _collision(contact: Contact, q: FloatArray, index: int) -> Collision:
    p = contact.proximity
    return Collision(
        p.body, p.other, p.distance, [float(v) for v in q], [float(v) for v in p.point], index
    )


class PathChecker:
    def __init__(self, world: World, robot: str, margin: float = 0.0) -> None:
        self.world = world
        self.robot = robot
        self.margin = margin
        self.bounds = world.robot(robot).reach_bounds()
        self.checks = 0

    def configuration(self, q: FloatArray) -> Collision | None:
        hit, _ = self._check(q)
        return None if hit is None else _collision(hit, q, 0)

    def _check(self, q: FloatArray) -> tuple[Contact | None, float]:
        """The contact that collides at `q` (nearer than the margin to anything else, or
        touching another link of the robot), if any, and how far any body point may travel
        from `q` before a contact could close."""
        outer = self.world.nearest(self.robot, q)
        inner = self.world.nearest_self(self.robot)  # placed at q just now
        self.checks += 1
        clearance = np.inf
        if outer is not None:
            clearance = outer.proximity.distance - self.margin
            if clearance <= 0:
                return outer, clearance
        if inner is not None:
            # The margin is for the scene: some links of a robot are closer than a margin
            # of a few cm at every pose (a UR5's forearm and wrist 2: 14 mm at home).
            if inner.proximity.distance <= 0:
                return inner, 0.0
            clearance = min(clearance, inner.proximity.distance / 2)
        return None, clearance

    def path(self, samples: FloatArray) -> Collision | None:
        """The first collision along the polyline through `samples` (rows of joints)."""
        if len(samples) == 1:
            return self.configuration(samples[0])
        for k in range(len(samples) - 1):
            hit = self._segment(samples[k], samples[k + 1])
            if hit is not None:
                return _with_index(hit, k)
        return None

    def _segment(self, a: FloatArray, b: FloatArray) -> Collision | None:
        delta = b - a
        travel = float(self.bounds @ np.abs(delta))  # worst body-point travel over a→b
        s = 0.0
        while True:
            q = a + s * delta
            hit, clearance = self._check(q)
            if hit is not None:
                return _collision(hit, q, 0)
            if s >= 1.0 or travel == 0.0:
                return None
            s = min(1.0, s + max(clearance, RESOLUTION) / travel)


def _with_index(hit: Collision, index: int) -> Collision:
    return Collision(hit.robot_part, hit.other, hit.distance, hit.position, hit.point, index)
