"""From a commanded TCP twist or joint velocity to safe joint velocities, one control cycle
at a time.

Cartesian jog solves a small QP each cycle:

    minimise  ‖W (J q̇ − ν)‖² + ρ ‖q̇‖²
    subject to  joint velocity limits, joint position limits within a short horizon,
                a change from the previous command the joints can make in one period
                (so the robot follows each command and its TCP speed is what was asked),
                and any extra constraints G q̇ ≤ h (the seam for collision avoidance),

with ρ growing near a singularity so the robot slows down there instead of jumping. In
manual reduced-speed mode the resulting TCP speed is capped (ISO 10218: 250 mm/s).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from qpsolvers import solve_qp

from runtime.interfaces.limits import FloatArray
from runtime.kinematics import Kinematics

MANUAL_TCP_SPEED = 0.25  # m/s
# Angular errors are weighed as the motion they cause at this distance from the TCP.
ANGULAR_WEIGHT = 0.3  # m
SINGULAR_BELOW = 0.04  # smallest weighted singular value where damping starts
MAX_DAMPING = 0.02
HORIZON = 0.15  # s: a joint slows so as not to reach its limit sooner than this

# Extra constraints: (q, jacobian) -> (G, h) meaning G q̇ ≤ h, or None.
Constraint = Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray] | None]


@dataclass
class VelocityStep:
    velocity: FloatArray
    tcp_speed: float
    smallest_singular_value: float = float("nan")
    capped: bool = False


@dataclass
class VelocityController:
    kinematics: Kinematics
    max_velocity: FloatArray
    max_acceleration: FloatArray
    period: float
    constraints: list[Constraint] = field(default_factory=list)

    def _bounds(self, q: FloatArray, previous: FloatArray | None) -> tuple[FloatArray, FloatArray]:
        k = self.kinematics
        lower = np.minimum(np.maximum(-self.max_velocity, (k.lower - q) / HORIZON), 0.0)
        upper = np.maximum(np.minimum(self.max_velocity, (k.upper - q) / HORIZON), 0.0)
        if previous is not None:
            reach = self.max_acceleration * self.period
            lower = np.maximum(lower, previous - reach)
            upper = np.minimum(upper, previous + reach)
            lower = np.minimum(lower, upper)  # braking for a limit wins over smoothness
        return lower, upper

    def from_twist(
        self,
        q: FloatArray,
        twist: FloatArray,
        tcp_cap: float | None,
        previous: FloatArray | None = None,
    ) -> VelocityStep:
        """Joint velocities that best give `twist` ([vx, vy, vz, wx, wy, wz] in the base
        frame, at the TCP) within every limit, starting from the `previous` command."""
        jacobian = self.kinematics.jacobian(q)
        weights = np.array([1.0, 1.0, 1.0, ANGULAR_WEIGHT, ANGULAR_WEIGHT, ANGULAR_WEIGHT])
        weighted = weights[:, None] * jacobian
        sigma = float(np.linalg.svd(weighted, compute_uv=False)[-1]) if q.size >= 6 else 0.0
        closeness = max(0.0, 1.0 - sigma / SINGULAR_BELOW)
        damping = 1e-6 + MAX_DAMPING * closeness**2
        hessian = weighted.T @ weighted + damping * np.eye(q.size)
        gradient = -weighted.T @ (weights * twist)
        lower, upper = self._bounds(q, previous)
        rows = [c(q, jacobian) for c in self.constraints]
        active = [r for r in rows if r is not None]
        g = np.vstack([r[0] for r in active]) if active else None
        h = np.concatenate([r[1] for r in active]) if active else None
        solution = solve_qp(hessian, gradient, G=g, h=h, lb=lower, ub=upper, solver="proxqp")
        velocity = np.zeros(q.size) if solution is None else np.asarray(solution, dtype=float)
        step = self._cap(jacobian, velocity, tcp_cap)
        step.smallest_singular_value = sigma
        return step

    def from_joint_velocity(
        self,
        q: FloatArray,
        velocity: FloatArray,
        tcp_cap: float | None,
        previous: FloatArray | None = None,
    ) -> VelocityStep:
        """A commanded joint velocity, slowed for the joint limits and the TCP speed cap."""
        lower, upper = self._bounds(q, previous)
        return self._cap(self.kinematics.jacobian(q), np.clip(velocity, lower, upper), tcp_cap)

    @staticmethod
    def _cap(jacobian: FloatArray, velocity: FloatArray, tcp_cap: float | None) -> VelocityStep:
        speed = float(np.linalg.norm(jacobian[:3] @ velocity))
        if tcp_cap is not None and speed > tcp_cap:
            return VelocityStep(velocity * (tcp_cap / speed), tcp_cap, capped=True)
        return VelocityStep(velocity, speed)
