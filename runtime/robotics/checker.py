"""Collision checking of a joint path by conservative advancement: a checked configuration's
clearance says how far any body point may travel before it could touch something else (its
room), and how far each pair of the robot's own links may move relative to each other before
they could touch; the next check comes when the travel since the last one could have used up
any of that room (or after `resolution` of travel when the room is smaller), so nothing
thicker than twice `resolution` is passed through unseen. A pair of links that a joint moves
as one (every link, for the base joint) has travelled nothing relative to each other: a
swing of the base alone is checked against the world only."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime.interfaces.limits import FloatArray
from runtime.robotics.world import Contact, World

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
        body = world.robot(robot)
        self.bounds = body.reach_bounds()
        self.pair_bounds = body.self_pair_bounds
        self.checks = 0

    def configuration(self, q: FloatArray) -> Collision | None:
        hit, _, _ = self._check(q)
        return None if hit is None else _collision(hit, q, 0)

    def _check(self, q: FloatArray) -> tuple[Contact | None, float, FloatArray]:
        """The contact that collides at `q` (nearer than the margin to anything else, or
        touching another link of the robot), if any; the room: how far any body point may
        travel from `q` before it could come within the margin of anything else, and how far
        each self pair's links may move relative to each other before they could touch."""
        self.checks += 1
        outer = self.world.nearest(self.robot, q)  # places the robot at q
        room = np.inf
        if outer is not None:
            room = outer.proximity.distance - self.margin
            if room <= 0:
                return outer, room, np.zeros(len(self.pair_bounds))
        # The margin is for the scene: some links of a robot are closer than a margin of a
        # few cm at every pose (a UR5's forearm and wrist 2: 14 mm at home).
        inner, pair_room = self.world.self_clearances(self.robot)
        return inner, room, pair_room

    def path(self, samples: FloatArray) -> Collision | None:
        """The first collision along the polyline through `samples` (rows of joints)."""
        hit, room, pair_room = self._check(samples[0])
        if hit is not None:
            return _collision(hit, samples[0], 0)
        for k in range(len(samples) - 1):
            a = samples[k]
            delta = samples[k + 1] - a
            step = np.abs(delta)
            rate = float(self.bounds @ step)  # worst body-point travel over the segment
            pair_rate = self.pair_bounds @ step  # worst relative travel of each self pair
            s = 0.0
            while True:
                ahead = _covered(room, pair_room, rate, pair_rate)
                if s + ahead >= 1.0:  # the room lasts past the segment's end: carry it on
                    room -= rate * (1.0 - s)
                    pair_room = pair_room - pair_rate * (1.0 - s)
                    break
                s = min(1.0, s + max(ahead, RESOLUTION / rate))
                q = a + s * delta
                hit, room, pair_room = self._check(q)
                if hit is not None:
                    return _collision(hit, q, k)
                if s >= 1.0:
                    break
        return None


def _covered(room: float, pair_room: FloatArray, rate: float, pair_rate: FloatArray) -> float:
    """The fraction of a segment the room lasts for (inf when the segment moves nothing)."""
    ahead = room / rate if rate > 0 else np.inf
    moving = pair_rate > 0
    if moving.any():
        ahead = min(ahead, float(np.min(pair_room[moving] / pair_rate[moving])))
    return ahead
