"""Geometric paths, sampled densely into joint positions: straight TCP lines with slerped
orientation, polylines through waypoints with their corners blended (quadratic Bézier
inside the blend radius), in joint or Cartesian space."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.words import words
from openpendant.runtime.robotics.kinematics import Kinematics, Unreachable

LINEAR_STEP = 0.001  # m between IK samples along a TCP path
ANGULAR_STEP = 0.005  # rad
JOINT_STEP = 0.002  # rad (joint-space norm) between samples of a joint path
# A jump larger than this between neighbouring samples of a TCP path means the arm has to
# swing round (a singularity, or a change of configuration) rather than follow the line.
MAX_JOINT_JUMP = 0.05  # rad per sample
# Smallest singular value of the Jacobian (angular rows weighed as motion at 0.3 m) below
# which the arm counts as singular.
SINGULAR_SIGMA = 0.01
ANGULAR_WEIGHT = 0.3


class PathError(InvalidValue):
    code = "path_infeasible"


@dataclass(frozen=True)
class Piece:
    """A line from a to b, or a quadratic Bézier from a to b pulled toward `corner`."""

    a: FloatArray
    b: FloatArray
    corner: FloatArray | None = None

    def at(self, u: float) -> FloatArray:
        if self.corner is None:
            return self.a + u * (self.b - self.a)
        return (1 - u) ** 2 * self.a + 2 * (1 - u) * u * self.corner + u**2 * self.b

    def length(self) -> float:
        if self.corner is None:
            return float(np.linalg.norm(self.b - self.a))
        points = np.array([self.at(u) for u in np.linspace(0, 1, 33)])
        return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


@dataclass(frozen=True)
class BlendedPolyline:
    pieces: list[Piece]
    # For each piece: the (segment index, fraction) of its start and end, so orientation can
    # be interpolated along with the position.
    spans: list[tuple[tuple[int, float], tuple[int, float]]]


def blended_polyline(points: FloatArray, radii: list[float]) -> BlendedPolyline:
    """Lines through `points` with the corner at points[i] rounded off within radii[i-1]
    (clipped to half of each neighbouring segment)."""
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    pieces: list[Piece] = []
    spans: list[tuple[tuple[int, float], tuple[int, float]]] = []
    start, start_span = points[0], (0, 0.0)
    for i in range(1, len(points) - 1):
        r = min(radii[i - 1], lengths[i - 1] / 2, lengths[i] / 2)
        if r <= 1e-9:
            pieces.append(Piece(start, points[i]))
            spans.append((start_span, (i - 1, 1.0)))
            start, start_span = points[i], (i, 0.0)
            continue
        f_in = 1 - r / lengths[i - 1]
        f_out = r / lengths[i]
        entry = points[i - 1] + f_in * (points[i] - points[i - 1])
        leave = points[i] + f_out * (points[i + 1] - points[i])
        pieces.append(Piece(start, entry))
        spans.append((start_span, (i - 1, f_in)))
        pieces.append(Piece(entry, leave, points[i]))
        spans.append(((i - 1, f_in), (i, f_out)))
        start, start_span = leave, (i, f_out)
    pieces.append(Piece(start, points[-1]))
    spans.append((start_span, (len(points) - 2, 1.0)))
    keep = [k for k, p in enumerate(pieces) if p.length() > 1e-12]
    return BlendedPolyline([pieces[k] for k in keep], [spans[k] for k in keep])


def sample_joint_polyline(points: FloatArray, radii: list[float]) -> FloatArray:
    """Dense joint positions along a joint-space polyline with blended corners."""
    path = blended_polyline(points, radii)
    rows = [points[0]]
    for piece in path.pieces:
        count = max(2, int(np.ceil(piece.length() / JOINT_STEP)) + 1)
        rows.extend(piece.at(u) for u in np.linspace(0, 1, count)[1:])
    return np.array(rows)


def _slerp(a: pin.Quaternion, b: pin.Quaternion, u: float) -> pin.Quaternion:
    return a.slerp(u, b)


def sample_tcp_path(
    kinematics: Kinematics, start: FloatArray, poses: list[pin.SE3], radii: list[float]
) -> FloatArray:
    """Joint positions that keep the TCP on the lines between `poses` (the first being where
    it is), corners blended within `radii` (m), orientation slerped along each segment. Fails
    before any motion if a sample is unreachable or the arm would have to jump."""
    for pose in poses[1:]:
        # A target nothing reaches is said so, not found as a "singularity" on the way.
        try:
            kinematics.inverse(pose, start)
        except Unreachable as exc:
            where = np.round(pose.translation * 1000).astype(int).tolist()
            away = round(float(np.linalg.norm(pose.translation)) * 1000)
            raise PathError(
                f"the target {where} mm ({away} mm from the base) is out of reach: no joint "
                "position puts the tool there within the joint limits",
                code="unreachable",
                words=words("motion.out_of_reach", where=str(where)),
            ) from exc
    positions = np.array([p.translation for p in poses])
    quats = [pin.Quaternion(p.rotation) for p in poses]
    for k in range(1, len(quats)):
        if quats[k - 1].dot(quats[k]) < 0:  # the short way round
            quats[k] = pin.Quaternion(-quats[k].coeffs())
    path = blended_polyline(positions, radii)

    def orientation(span: tuple[int, float]) -> pin.Quaternion:
        segment, fraction = span
        return _slerp(quats[segment], quats[segment + 1], fraction)

    q = np.asarray(start, dtype=float)
    rows = [q.copy()]
    pieces = path.pieces or [Piece(positions[0], positions[-1])]
    spans = path.spans or [((0, 0.0), (len(poses) - 2, 1.0))]
    for piece, (span_a, span_b) in zip(pieces, spans, strict=True):
        qa, qb = orientation(span_a), orientation(span_b)
        angle = qa.angularDistance(qb)
        count = int(np.ceil(max(piece.length() / LINEAR_STEP, angle / ANGULAR_STEP)))
        for u in np.linspace(0, 1, max(count, 1) + 1)[1:]:
            target = pin.SE3(_slerp(qa, qb, u).toRotationMatrix(), piece.at(u))
            try:
                nxt = kinematics.inverse(target, q, restarts=0)
            except Unreachable as exc:
                where = np.round(target.translation * 1000).astype(int).tolist()
                raise PathError(
                    f"the line leaves the workspace near {where} mm",
                    code="unreachable",
                    words=words("motion.leaves_workspace", where=str(where)),
                ) from exc
            if np.max(np.abs(nxt - q)) > MAX_JOINT_JUMP or _singular(kinematics, nxt):
                where = np.round(target.translation * 1000).astype(int).tolist()
                raise PathError(
                    f"the line passes through a singularity near {where} mm",
                    code="singularity",
                    words=words("motion.singularity", where=str(where)),
                )
            q = nxt
            rows.append(q)
    return np.array(rows)


def _singular(kinematics: Kinematics, q: FloatArray) -> bool:
    jacobian = kinematics.jacobian(q)
    jacobian[3:] *= ANGULAR_WEIGHT
    return bool(np.linalg.svd(jacobian, compute_uv=False)[-1] < SINGULAR_SIGMA)
