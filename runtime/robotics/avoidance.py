"""Real-time collision avoidance as constraints of the velocity QP (the PyRI formulation,
seed paper §IV-C, eq. 1–2): for each pair of a robot part and another body closer than the
influence distance, with nearest points p (on the robot) and o, and n = (o − p)/‖o − p‖,

    nᵀ J_p(q) q̇ ≤ ξ (d − d_s) / (d_i − d_s)

so the part may approach the other body ever slower and never nearer than d_s; when closer
than d_s the bound turns negative and pushes it away. J_p is the Jacobian of the point p."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.world import Contact, World

INFLUENCE = 0.15  # m: pairs further apart than this add no constraint
SAFETY = 0.02  # m: the distance kept
APPROACH_SPEED = 0.25  # m/s (ξ): the fastest approach allowed at the influence distance


@dataclass
class AvoidanceConstraint:
    """Callable as the velocity controller's constraint seam: (q, jacobian) → (G, h)."""

    world: World
    robot: str
    influence: float = INFLUENCE
    safety: float = SAFETY
    approach_speed: float = APPROACH_SPEED
    nearest: Contact | None = None  # of the last cycle, for display

    def __call__(
        self, q: FloatArray, _jacobian: FloatArray
    ) -> tuple[FloatArray, FloatArray] | None:
        contacts = self.world.contacts(self.robot, q, within=self.influence)
        self.nearest = min(contacts, key=lambda c: c.proximity.distance, default=None)
        if not contacts:
            return None
        body = self.world.robot(self.robot)
        rows, bounds = [], []
        for contact in contacts:
            p = contact.proximity
            normal = p.other_point - p.point
            length = float(np.linalg.norm(normal))
            if length < 1e-9:  # touching: push away from the other body's centre
                normal = self._centre_of(p.other) - p.point
                length = float(np.linalg.norm(normal)) or 1.0
            if p.distance < 0:  # inside: the nearest points point out of the other body
                normal = -normal
            normal /= length
            jacobian = body.point_jacobian(contact.part, p.point)
            rows.append(normal @ jacobian)
            scale = (p.distance - self.safety) / (self.influence - self.safety)
            if self._is_robot(p.other):
                scale /= 2  # the other robot may approach as fast: each takes half
            bounds.append(self.approach_speed * scale)
        return np.array(rows), np.array(bounds)

    def _is_robot(self, shape: str) -> bool:
        owner, _, part = shape.partition("/")
        return bool(part) and owner != self.robot and owner in self.world.robots

    def _centre_of(self, name: str) -> FloatArray:
        for shape in self.world.obstacles:
            if shape.name == name:
                return shape.world_center
        for body in self.world.robots.values():
            for shape in body.shapes:
                if shape.name == name:
                    return shape.world_center
        return np.zeros(3)
