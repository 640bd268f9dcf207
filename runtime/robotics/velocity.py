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

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.kinematics import Kinematics

MANUAL_TCP_SPEED = 0.25  # m/s
# Angular errors are weighed as the motion they cause at this distance from the TCP.
ANGULAR_WEIGHT = 0.3  # m
SINGULAR_BELOW = 0.04  # smallest weighted singular value where damping starts
MAX_DAMPING = 0.02
HORIZON = 0.15  # s: a joint slows so as not to reach its limit sooner than this
# A well-posed step converges in tens of iterations; an infeasible one (collision bounds
# against the per-cycle acceleration bounds) would otherwise iterate for seconds and stall
# the control loop. Not converging counts as no solution.
MAX_ITERATIONS = 200

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
        linear_speed = float(np.linalg.norm(twist[:3]))
        if tcp_cap is not None and linear_speed > tcp_cap:
            # Capped as asked, not after: solved for a faster twist, the joints could not
            # change by as much in one period, and the least-squares answer within their
            # limits turned the TCP off its direction (a reactive move in manual mode left its
            # line by 40 mm).
            twist = twist * (tcp_cap / linear_speed)
        weights = np.array([1.0, 1.0, 1.0, ANGULAR_WEIGHT, ANGULAR_WEIGHT, ANGULAR_WEIGHT])
        weighted = weights[:, None] * jacobian
        sigma = float(np.linalg.svd(weighted, compute_uv=False)[-1]) if q.size >= 6 else 0.0
        closeness = max(0.0, 1.0 - sigma / SINGULAR_BELOW)
        damping = 1e-6 + MAX_DAMPING * closeness**2
        hessian = weighted.T @ weighted + damping * np.eye(q.size)
        gradient = -weighted.T @ (weights * twist)
        g, h = self._extra(q, jacobian)
        velocity = self._solve(q, hessian, gradient, g, h, previous)
        step = self._cap(jacobian, velocity, tcp_cap)
        step.smallest_singular_value = sigma
        return step

    def _solve(
        self,
        q: FloatArray,
        hessian: FloatArray,
        gradient: FloatArray,
        g: FloatArray | None,
        h: FloatArray | None,
        previous: FloatArray | None,
    ) -> FloatArray:
        if previous is not None and g is None:
            # The best velocity within every limit but the change from `previous`, then
            # approached along a straight line in joint space, as far as every joint can
            # change in one period: all joints in step, so the TCP keeps its direction
            # while it speeds up (a QP bounding each joint's change on its own turned it).
            # Near an obstacle keeping clear decides the direction: the QP below.
            lower, upper = self._bounds(q, None)
            target = _qp(hessian, gradient, None, None, lower, upper)
            if target is not None:
                change = target - previous
                reach = self.max_acceleration * self.period
                ratio = float(np.max(np.abs(change) / reach))
                step = previous + change / max(ratio, 1.0)
                if np.all(step >= lower - 1e-9) and np.all(step <= upper + 1e-9):
                    return step
        lower, upper = self._bounds(q, previous)
        solution = _qp(hessian, gradient, g, h, lower, upper)
        if solution is None and g is not None:
            # Keeping clear wins over smoothness: the driver still limits acceleration.
            lower, upper = self._bounds(q, None)
            solution = _qp(hessian, gradient, g, h, lower, upper)
        return np.zeros(q.size) if solution is None else solution

    def _extra(
        self, q: FloatArray, jacobian: FloatArray
    ) -> tuple[FloatArray | None, FloatArray | None]:
        rows = [c(q, jacobian) for c in self.constraints]
        active = [r for r in rows if r is not None]
        if not active:
            return None, None
        return np.vstack([r[0] for r in active]), np.concatenate([r[1] for r in active])

    def from_joint_velocity(
        self,
        q: FloatArray,
        velocity: FloatArray,
        tcp_cap: float | None,
        previous: FloatArray | None = None,
    ) -> VelocityStep:
        """A commanded joint velocity, slowed for the joint limits, the TCP speed cap and,
        near an obstacle, as much as keeping clear needs. Only slowed, never turned: a
        technician jogging one joint expects no other joint to move."""
        jacobian = self.kinematics.jacobian(q)
        lower, upper = self._bounds(q, previous)
        wanted = np.clip(velocity, lower, upper)
        g, h = self._extra(q, jacobian)
        if g is not None and h is not None:
            approach = g @ wanted
            closing = approach > 1e-12
            if np.any(closing):
                # Braking harder than one cycle allows is left to the driver's limits.
                wanted = wanted * float(np.clip(np.min(h[closing] / approach[closing]), 0, 1))
        return self._cap(jacobian, wanted, tcp_cap)

    @staticmethod
    def _cap(jacobian: FloatArray, velocity: FloatArray, tcp_cap: float | None) -> VelocityStep:
        speed = float(np.linalg.norm(jacobian[:3] @ velocity))
        if tcp_cap is not None and speed > tcp_cap:
            return VelocityStep(velocity * (tcp_cap / speed), tcp_cap, capped=True)
        return VelocityStep(velocity, speed)


def _qp(
    hessian: FloatArray,
    gradient: FloatArray,
    g: FloatArray | None,
    h: FloatArray | None,
    lower: FloatArray,
    upper: FloatArray,
) -> FloatArray | None:
    solution = solve_qp(
        hessian, gradient, G=g, h=h, lb=lower, ub=upper, solver="proxqp", max_iter=MAX_ITERATIONS
    )
    return None if solution is None else np.asarray(solution, dtype=float)
