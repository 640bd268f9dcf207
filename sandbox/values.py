"""Values programs hold: poses and waypoint references. Programs see millimetres and degrees,
as the pendant shows them; the runtime gets metres and quaternions (DESIGN §3).

Orientation as roll, pitch, yaw: R = Rz(yaw) · Ry(pitch) · Rx(roll), about fixed axes."""

from __future__ import annotations

import math
from typing import Any

from openpendant.sandbox.guards import SandboxError, register_value_type

Quaternion = tuple[float, float, float, float]  # x, y, z, w
Vector = tuple[float, float, float]


def check_number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SandboxError(f"{what} must be a number, not {type(value).__name__}")
    number = float(value)
    if not math.isfinite(number):
        raise SandboxError(f"{what} must be a finite number, not {number}")
    return number


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> Quaternion:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def rpy_from_quat(q: Quaternion) -> Vector:
    x, y, z, w = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def quat_multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_rotate(q: Quaternion, v: Vector) -> Vector:
    x, y, z, _ = quat_multiply(quat_multiply(q, (v[0], v[1], v[2], 0.0)), conjugate(q))
    return x, y, z


def conjugate(q: Quaternion) -> Quaternion:
    return -q[0], -q[1], -q[2], q[3]


def normalized(q: Quaternion) -> Quaternion:
    norm = math.sqrt(sum(c * c for c in q))
    if not math.isfinite(norm) or norm < 1e-9:
        raise SandboxError("an orientation quaternion must have a non-zero finite length")
    return q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm


class Pose:
    """A position and orientation. Read x, y, z (mm) and roll, pitch, yaw (degrees)."""

    __slots__ = ("_orientation", "_position")

    def __init__(self, position: Vector, orientation: Quaternion) -> None:
        self._position = position
        self._orientation = normalized(orientation)

    @classmethod
    def from_user(cls, x: Any, y: Any, z: Any, roll: Any = 0, pitch: Any = 0, yaw: Any = 0) -> Pose:
        mm = [check_number(v, n) / 1000.0 for v, n in ((x, "x"), (y, "y"), (z, "z"))]
        rad = [
            math.radians(check_number(v, n))
            for v, n in ((roll, "roll"), (pitch, "pitch"), (yaw, "yaw"))
        ]
        return cls((mm[0], mm[1], mm[2]), quat_from_rpy(*rad))

    @classmethod
    def from_wire(cls, data: Any) -> Pose:
        """From the runtime's {"position": [m], "orientation": [x, y, z, w]}."""
        try:
            p = [float(v) for v in data["position"]]
            q = [float(v) for v in data["orientation"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise SandboxError(f"not a pose: {data!r:.80}") from exc
        if len(p) != 3 or len(q) != 4:
            raise SandboxError("a pose has 3 position and 4 orientation values")
        return cls((p[0], p[1], p[2]), (q[0], q[1], q[2], q[3]))

    def wire(self) -> dict[str, list[float]]:
        return {"position": list(self._position), "orientation": list(self._orientation)}

    @property
    def position(self) -> Vector:
        return self._position

    @property
    def orientation(self) -> Quaternion:
        return self._orientation

    @property
    def x(self) -> float:
        return self._position[0] * 1000.0

    @property
    def y(self) -> float:
        return self._position[1] * 1000.0

    @property
    def z(self) -> float:
        return self._position[2] * 1000.0

    @property
    def roll(self) -> float:
        return math.degrees(rpy_from_quat(self._orientation)[0])

    @property
    def pitch(self) -> float:
        return math.degrees(rpy_from_quat(self._orientation)[1])

    @property
    def yaw(self) -> float:
        return math.degrees(rpy_from_quat(self._orientation)[2])

    def compose(self, other: Pose) -> Pose:
        moved = quat_rotate(self._orientation, other._position)
        position = (
            self._position[0] + moved[0],
            self._position[1] + moved[1],
            self._position[2] + moved[2],
        )
        return Pose(position, quat_multiply(self._orientation, other._orientation))

    def inverse(self) -> Pose:
        q = conjugate(self._orientation)
        p = quat_rotate(q, self._position)
        return Pose((-p[0], -p[1], -p[2]), q)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pose):
            return NotImplemented
        return self._position == other._position and self._orientation == other._orientation

    def __hash__(self) -> int:
        return hash((self._position, self._orientation))

    def __repr__(self) -> str:
        return (
            f"Pose(x={self.x:.1f}, y={self.y:.1f}, z={self.z:.1f}, "
            f"roll={self.roll:.1f}, pitch={self.pitch:.1f}, yaw={self.yaw:.1f})"
        )


class Waypoint:
    """A taught waypoint, by name; the runtime looks it up when a move uses it."""

    __slots__ = ("_kind", "_name")

    def __init__(self, name: str, kind: str) -> None:
        self._name = name
        self._kind = kind

    @property
    def name(self) -> str:
        return self._name

    @property
    def kind(self) -> str:
        return self._kind

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Waypoint) and other._name == self._name

    def __hash__(self) -> int:
        return hash(self._name)

    def __repr__(self) -> str:
        return f"waypoint {self._name!r}"


register_value_type(Pose, ("x", "y", "z", "roll", "pitch", "yaw"))
register_value_type(Waypoint, ("name", "kind"))
