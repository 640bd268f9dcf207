"""From a move request to a checked, timed joint trajectory (no I/O here: the service
resolves stored waypoints and the robot's state first)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.kit.errors import InvalidValue, OpenPendantError
from openpendant.runtime.kit.words import words
from openpendant.runtime.motion.models import (
    CollisionReport,
    MoveKind,
    MoveRequest,
    PlanReport,
    Target,
)
from openpendant.runtime.robotics.checker import Collision, PathChecker
from openpendant.runtime.robotics.joint_move import plan_joint_move
from openpendant.runtime.robotics.kinematics import pose_to_se3
from openpendant.runtime.robotics.paths import sample_joint_polyline, sample_tcp_path
from openpendant.runtime.robotics.planner import plan_around
from openpendant.runtime.robotics.reference import Limits
from openpendant.runtime.robotics.timing import SAMPLE_PERIOD, TimedPath, at_rest, time_scale
from openpendant.runtime.robotics.world import World

PREVIEW_POINTS = 300
ALTERNATIVES = 8  # a pose's other joint solutions tried when the nearest collides there


@dataclass(frozen=True)
class Point:
    """A resolved target: joints, or a TCP pose in the robot's base frame."""

    joints: FloatArray | None
    pose: pin.SE3 | None
    blend: float = 0.0


@dataclass
class Plan:
    report: PlanReport
    timed: TimedPath | None = None


class Refused(InvalidValue):
    code = "move_refused"


def resolve(target: Target, world_base: pin.SE3, limits: JointLimitChecker) -> Point:
    """A target given as joints or pose (stored waypoints are already looked up)."""
    if target.joints is not None:
        return Point(limits.positions(target.joints, "target"), None, target.blend)
    if target.pose is None:
        raise InvalidValue("the target has neither joints nor a pose")
    pose = pose_to_se3(target.pose)
    if target.frame == "world":
        pose = world_base.actInv(pose)
    return Point(None, pose, target.blend)


class MovePlanner:
    def __init__(self, world: World, robot: str, tcp_cap: float | None) -> None:
        self.world = world
        self.robot = robot
        self.body = world.robot(robot)
        self.kinematics = self.body.kinematics
        self.info = self.kinematics.info
        self.tcp_cap = tcp_cap

    def plan(self, request: MoveRequest, start: FloatArray, points: list[Point]) -> Plan:
        checker = PathChecker(self.world, self.robot, request.margin)
        try:
            return self._plan(request, start, points, checker)
        except OpenPendantError as exc:
            return Plan(PlanReport(ok=False, code=exc.code, message=exc.message, words=exc.words))

    def _plan(
        self, request: MoveRequest, start: FloatArray, points: list[Point], checker: PathChecker
    ) -> Plan:
        kind = request.kind
        around = False
        if kind is MoveKind.joint:
            goal = self._joint_goal(points[0], start, checker)
            vertices = np.array([start, goal])
            collision = checker.path(vertices)  # the straight joint line
            if collision is not None and request.avoid_obstacles:
                timed = self._around(checker, start, goal, request)
                around, collision = True, None
            if collision is not None:
                return self._refused(collision, sample_joint_polyline(vertices, []))
            if not around:
                timed = self._joint_segments(vertices, request)
        else:
            samples = self._tcp_or_joint_path(request, start, points)
            collision = checker.path(samples)
            if collision is not None:
                return self._refused(collision, samples)
            timed = self._time(samples, request, self._stops_at_corners(request, points))
        # Slowed where the drivers' interpolation of the samples would pass a joint's limits
        # (ruckig's own profiles between joint-move samples can, by a few percent): the
        # duration planned is the one that runs.
        timed = timed.within(Limits.of(self.info.joints))
        if not around:  # a path around was checked as it runs, where it was planned
            # The trajectory interpolates between its points: check what will actually run.
            collision = checker.path(timed.positions)
            if collision is not None:
                return self._refused(collision, timed.positions)
        report = PlanReport(
            ok=True,
            duration=timed.duration,
            planned_around=around,
            tcp_path=self._preview(timed.positions),
            goal=[float(v) for v in timed.positions[-1]],
        )
        return Plan(report, timed)

    # Paths ----------------------------------------------------------------------------------

    def _joints(self, point: Point, seed: FloatArray) -> FloatArray:
        if point.joints is not None:
            return point.joints
        assert point.pose is not None
        return self.kinematics.inverse(point.pose, seed)

    def _joint_goal(self, point: Point, start: FloatArray, checker: PathChecker) -> FloatArray:
        """A pose's joints for a joint move: the solution reached from the start, unless the
        arm would collide there (the elbow or wrist folded into the base, say) and another
        of the pose's solutions would not: then the nearest of those."""
        goal = self._joints(point, start)
        if point.pose is None or checker.configuration(goal) is None:
            return goal
        for other in self.kinematics.solutions(point.pose, start)[:ALTERNATIVES]:
            if checker.configuration(other) is None:
                return other
        return goal  # refused with the first solution's collision, as it would be

    def _pose(self, point: Point) -> pin.SE3:
        if point.pose is not None:
            return point.pose
        assert point.joints is not None
        return self.kinematics.tcp(point.joints).copy()

    def _tcp_or_joint_path(
        self, request: MoveRequest, start: FloatArray, points: list[Point]
    ) -> FloatArray:
        here = self.kinematics.tcp(start).copy()
        if request.kind is MoveKind.relative:
            assert request.offset is not None
            offset = pose_to_se3(request.offset)
            if request.offset_frame == "tool":
                goal = here * offset
            else:
                goal = pin.SE3(
                    offset.rotation @ here.rotation, here.translation + offset.translation
                )
            return sample_tcp_path(self.kinematics, start, [here, goal], [])
        if request.kind is MoveKind.linear:
            return sample_tcp_path(self.kinematics, start, [here, self._pose(points[0])], [])
        radii = [p.blend for p in points[:-1]]
        if request.linear:
            poses = [here] + [self._pose(p) for p in points]
            return sample_tcp_path(self.kinematics, start, poses, radii)
        vertices = [start]
        for p in points:
            vertices.append(self._joints(p, vertices[-1]))
        return sample_joint_polyline(np.array(vertices), radii)

    @staticmethod
    def _stops_at_corners(request: MoveRequest, points: list[Point]) -> bool:
        """Whether the path stops at some waypoint on the way (one without a blend)."""
        return request.kind is MoveKind.path and any(p.blend <= 0.0 for p in points[:-1])

    def _around(
        self, checker: PathChecker, start: FloatArray, goal: FloatArray, request: MoveRequest
    ) -> TimedPath:
        """A path planned around the obstacles, timed: the planner tries again while the
        path check finds a collision on what would run."""
        timed: list[TimedPath] = []

        def verify(vertices: FloatArray) -> Collision | None:
            candidate = self._joint_segments(vertices, request)
            collision = checker.path(candidate.positions)
            if collision is None:
                timed.append(candidate)
            return collision

        plan_around(
            checker, start, goal, self.kinematics.lower, self.kinematics.upper, verify=verify
        )
        return timed[-1]

    # Timing -----------------------------------------------------------------------------------

    def _time(self, samples: FloatArray, request: MoveRequest, stops: bool) -> TimedPath:
        """Rest to rest, stopping at the path's unblended corners when it has any."""
        pieces = _split_at_corners(samples) if stops else [samples]
        timed = at_rest(samples[0])
        for piece in pieces:
            timed = timed.then(
                time_scale(
                    piece,
                    self.info,
                    speed=request.speed,
                    acceleration=request.acceleration,
                    kinematics=self.kinematics,
                    tcp_cap=self.tcp_cap,
                )
            )
        return timed

    def _joint_segments(self, vertices: FloatArray, request: MoveRequest) -> TimedPath:
        """Joint moves from vertex to vertex, stopping at each (ruckig, phase-synchronized:
        each the straight joint line that was checked)."""
        timed = at_rest(vertices[0])
        for a, b in itertools.pairwise(vertices):
            move = plan_joint_move(
                self.kinematics,
                self.info,
                a,
                b,
                request.speed,
                self.tcp_cap,
                acceleration=request.acceleration,
                fraction=1.0,
            )
            if move.duration < SAMPLE_PERIOD / 10:  # already there
                continue
            count = max(2, int(np.ceil(move.duration / SAMPLE_PERIOD)) + 1)
            times = np.linspace(0.0, move.duration, count)
            states = [move.state(float(t)) for t in times]
            positions = np.array([s[0] for s in states])
            velocities = np.array([s[1] for s in states])
            accelerations = np.array([s[2] for s in states])
            positions[-1], velocities[-1], accelerations[-1] = b, 0.0, 0.0
            timed = timed.then(TimedPath(times, positions, velocities, accelerations))
        return timed

    # Reports ----------------------------------------------------------------------------------

    def _preview(self, samples: FloatArray) -> list[list[float]]:
        step = max(1, len(samples) // PREVIEW_POINTS)
        picked = [*list(samples[::step]), samples[-1]]
        world = self.body.world_base
        return [
            [round(float(v), 5) for v in world.act(self.kinematics.tcp(q).translation)]
            for q in picked
        ]

    def _refused(self, collision: Collision, samples: FloatArray) -> Plan:
        report = PlanReport(
            ok=False,
            code="collision",
            message=f"the move is refused: {collision.describe()}",
            words=words("motion.collision", part=collision.robot_part, other=collision.other),
            collision=CollisionReport(
                robot_part=collision.robot_part,
                other=collision.other,
                distance=collision.distance,
                position=collision.position,
                point=collision.point,
                message=collision.describe(),
            ),
            tcp_path=self._preview(samples),
        )
        return Plan(report)


def _split_at_corners(samples: FloatArray) -> list[FloatArray]:
    """Split a sampled polyline where its direction turns sharply (unblended corners)."""
    steps = np.diff(samples, axis=0)
    norms = np.linalg.norm(steps, axis=1)
    cuts = [0]
    for k in range(1, len(steps)):
        if norms[k] < 1e-12 or norms[k - 1] < 1e-12:
            continue
        cosine = float(steps[k] @ steps[k - 1]) / (norms[k] * norms[k - 1])
        if cosine < 0.9:
            cuts.append(k)
    cuts.append(len(samples) - 1)
    return [samples[a : b + 1] for a, b in itertools.pairwise(cuts) if b > a]
