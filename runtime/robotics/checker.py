"""Collision checking of a joint path by conservative advancement. A checked configuration's
clearances give each moving part its room (how far it may travel before it could come within
the margin of anything else) and each pair of the robot's own links theirs (how far they may
move relative to each other before they could touch). Travel along the path is bounded per
part and per pair from the joints that move them, so each room is used up at a known point;
the next check comes at the first such point (or after `resolution` of travel of any body
point, when that is further), so nothing thicker than twice `resolution` is passed through
unseen. A room that is not used up still holds less what was travelled since it was measured:
a check measures afresh only the rooms that have run low. A part near the table that only the
base joint turns may swing far on one measurement while the wrist's is used up quickly; a
pair of links that a joint moves as one (every link, for the base joint) has travelled
nothing relative to each other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.robotics.world import Contact, World

RESOLUTION = 0.004  # m of travel of any body point between checks, at worst
# A part whose bounds put it nearer than this beyond the margin gets its exact distance:
# further away, the bound's room is plenty and FCL is not asked.
NEAR = 0.05
# A room is measured afresh once it has run down to this share of what it was when measured
# (and always once it is used up): a little early, so that one check serves several rooms.
RENEW = 0.5


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
        body = world.robot(robot)
        # One row per room: each moving part's, then each self pair's; per joint, how far a
        # step of it can use the room up.
        self.room_bounds = np.vstack((body.part_reach_bounds(), body.self_pair_bounds))
        self.parts = len(body.moving)
        self.bounds = body.reach_bounds()  # of any body point, for the resolution
        self.checks = 0

    def configuration(self, q: FloatArray) -> Collision | None:
        room = np.empty(len(self.room_bounds))
        hit = self._measure(q, room, np.ones(len(room), dtype=bool))
        return None if hit is None else _collision(hit, q, 0)

    def _measure(self, q: FloatArray, room: FloatArray, which: np.ndarray) -> Contact | None:
        """Measures the rooms `which` picks at `q` into `room`; the contact that collides
        there (nearer than the margin to anything else, or touching another link of the
        robot), if one does."""
        self.checks += 1
        parts = np.nonzero(which[: self.parts])[0]
        pairs = np.nonzero(which[self.parts :])[0]
        # Places the robot at q. The clearances are lower bounds, exact wherever they are
        # near the margin: one at or under it is a collision.
        clear = self.world.part_clearances(self.robot, q, self.margin + NEAR, parts)
        room[parts] = clear - self.margin
        # The margin is for the scene: some links of a robot are closer than a margin of a
        # few cm at every pose (a UR5's forearm and wrist 2: 14 mm at home).
        room[self.parts + pairs] = self.world.self_clearances(self.robot, pairs)[1]
        if not np.any(room[which] <= 0):
            return None
        # Named as a whole check names it: the nearest pair within the margin, else the
        # deepest pair of links touching.
        outer = self.world.nearest(self.robot)
        if outer is not None and outer.proximity.distance <= self.margin:
            return outer
        inner, _ = self.world.self_clearances(self.robot)
        assert inner is not None
        return inner

    def path(self, samples: FloatArray) -> Collision | None:
        """The first collision along the polyline through `samples` (rows of joints)."""
        fresh = np.empty(len(self.room_bounds))  # each room as last measured
        hit = self._measure(samples[0], fresh, np.ones(len(fresh), dtype=bool))
        if hit is not None:
            return _collision(hit, samples[0], 0)
        along = _Travel(samples, self.room_bounds, self.bounds)
        ends = fresh.copy()  # how far along each room's own travel it is used up
        at = 0.0  # where on the path: segment index plus the fraction of it
        while True:
            used_up = along.first(ends)
            if used_up >= along.end:
                return None  # every room lasts to the end
            # At worst `resolution` of travel of any body point, however small the room.
            at = min(max(used_up, along.after(at, RESOLUTION)), along.end)
            q = along.position(at)
            travelled = along.rooms(at)
            renew = ends - travelled <= RENEW * fresh
            hit = self._measure(q, fresh, renew)
            if hit is not None:
                return _collision(hit, q, min(int(at), len(samples) - 2))
            ends[renew] = travelled[renew] + fresh[renew]
            if at >= along.end:
                return None


class _Travel:
    """How far each room has been travelled into, and any body point at worst, from the
    start of a polyline to a point on it (segment index plus fraction): piecewise linear,
    summed once for the whole path so that a check can jump to the next point it needs."""

    def __init__(self, samples: FloatArray, room_bounds: FloatArray, bounds: FloatArray) -> None:
        self.samples = samples
        self.deltas = np.diff(samples, axis=0)
        steps = np.abs(self.deltas)
        self.end = float(len(steps))
        rows = len(room_bounds)
        self.travel = np.vstack((np.zeros(rows), np.cumsum(steps @ room_bounds.T, axis=0)))
        self.worst = np.concatenate(([0.0], np.cumsum(steps @ bounds)))
        # Every room's column one after the other, each lifted above the last: one sorted
        # array, so one search finds where each room is used up.
        span = float(self.travel[-1].max(initial=0.0)) + 1.0
        self.lift = span * np.arange(rows)
        self.stacked = (self.travel + self.lift).T.ravel()
        self.column = len(samples) * np.arange(rows)

    def _split(self, at: float) -> tuple[int, float]:
        k = min(int(at), len(self.deltas) - 1)
        return k, at - k

    def position(self, at: float) -> FloatArray:
        k, t = self._split(at)
        position: FloatArray = self.samples[k] + t * self.deltas[k]
        return position

    def rooms(self, at: float) -> FloatArray:
        k, t = self._split(at)
        travel: FloatArray = self.travel[k] + t * (self.travel[k + 1] - self.travel[k])
        return travel

    def first(self, ends: FloatArray) -> float:
        """The first point where some room's travel reaches its end (inf: none does)."""
        index = np.searchsorted(self.stacked, ends + self.lift) - self.column
        reached = np.nonzero(index < len(self.samples))[0]
        if reached.size == 0:
            return np.inf
        upper = np.maximum(index[reached], 1)
        low = self.travel[upper - 1, reached]
        high = self.travel[upper, reached]
        return float(np.min(upper - 1 + (ends[reached] - low) / (high - low)))

    def after(self, at: float, distance: float) -> float:
        """The point where any body point may have travelled `distance` since `at`."""
        k, t = self._split(at)
        target = float(self.worst[k] + t * (self.worst[k + 1] - self.worst[k])) + distance
        upper = int(np.searchsorted(self.worst, target))
        if upper >= len(self.samples):
            return np.inf
        upper = max(upper, 1)
        low, high = float(self.worst[upper - 1]), float(self.worst[upper])
        return upper - 1 + (target - low) / (high - low)
