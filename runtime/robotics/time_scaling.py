"""How fast a running trajectory's clock goes: 1 as planned, the speed override below that,
0 paused. The rate changes smoothly, with its own rate of change and acceleration bounded
so that the reference, time-scaled, stays within every joint's acceleration and jerk limits:
a pause is a controlled stop along the path, and resuming continues along it. (Changing
the rate in one step made the reference jump; the tracker then cut across to catch up.)"""

from __future__ import annotations

import math

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray

# Share of a joint's jerk limit a change of rate may add; and of its acceleration limit the
# scaled reference may use (the tracker needs some room to follow).
HEADROOM = 0.5
ACCELERATION_SHARE = 0.8
MAX_RATE_SPEED = 4.0  # 1/s: no faster than a quarter second from full speed to a stop
SETTLED = 1e-9


class TimeScaling:
    def __init__(self, max_acceleration: FloatArray, max_jerk: FloatArray) -> None:
        self.max_acceleration = max_acceleration
        self.max_jerk = np.where(np.isfinite(max_jerk), max_jerk, 20.0 * max_acceleration)
        self.rate = 1.0
        self.rate_speed = 0.0  # d rate / dt

    def step(
        self, target: float, velocity: FloatArray, acceleration: FloatArray, dt: float
    ) -> None:
        """One cycle toward `target` (0 to 1), for a reference whose planned (unscaled)
        velocity and acceleration are these now."""
        gap = target - self.rate
        if abs(gap) < SETTLED and abs(self.rate_speed) < SETTLED:
            self.rate, self.rate_speed = target, 0.0
            return
        # Scaled, the reference accelerates by a·r² + v·r' and jerks by about v·r'': r' is
        # kept where every joint's acceleration stays within its limit, r'' where the jerk
        # added stays within a share of the jerk limit.
        low, high = -MAX_RATE_SPEED, MAX_RATE_SPEED
        max_accel = MAX_RATE_SPEED / 0.05
        moving = np.abs(velocity) > 1e-9
        if np.any(moving):
            v, a = velocity[moving], acceleration[moving] * self.rate * self.rate
            limit = ACCELERATION_SHARE * self.max_acceleration[moving]
            one, other = (-limit - a) / v, (limit - a) / v
            low = max(low, float(np.max(np.minimum(one, other))))
            high = min(high, float(np.min(np.maximum(one, other))))
            max_accel = min(max_accel, HEADROOM * float(np.min(self.max_jerk[moving] / np.abs(v))))
        # The speed that still stops at the target with the acceleration allowed.
        wanted = math.copysign(math.sqrt(2.0 * max_accel * abs(gap)), gap)
        wanted = min(high, max(low, wanted)) if low <= high else 0.0
        change = max(-max_accel * dt, min(max_accel * dt, wanted - self.rate_speed))
        self.rate_speed += change
        new_rate = self.rate + self.rate_speed * dt
        if (gap > 0 and new_rate >= target) or (gap < 0 and new_rate <= target):
            new_rate, self.rate_speed = target, 0.0
        self.rate = min(1.0, max(0.0, new_rate))
