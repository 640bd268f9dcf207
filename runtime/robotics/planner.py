"""Joint-space global planning around obstacles: OMPL's RRT-Connect searching with a quick
collision screen (pinocchio's collision model, many configurations per call), its path
shortened, then proven collision-free by the conservative path checker before anyone may
execute it. A path the checker refuses is searched for again.

The search looks first near the start and the goal (a box about both, a little wider), where
a short path lies when there is one; then over the whole joint range."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.kit.words import words
from openpendant.runtime.robotics.checker import Collision, PathChecker
from openpendant.runtime.robotics.screen import Screen
from openpendant.runtime.robotics.shortcut import shortcut

ou.setLogLevel(ou.LogLevel.LOG_WARN)
# The same searches in the same order find the same paths (OMPL seeds each planner from this).
ou.RNG.setSeed(1)

SEARCH_RESOLUTION = 0.05  # m of travel of any body point between the search's checks
NEAR_BOX = 0.8  # rad beyond the start and the goal, each way, for the first searches
# (how far the search may look: the near box or the whole range; its share of the time)
ATTEMPTS: tuple[tuple[float | None, float], ...] = (
    (NEAR_BOX, 0.05),
    (NEAR_BOX, 0.05),
    (None, 0.45),
    (None, 0.45),
)

Verify = Callable[[FloatArray], Collision | None]


class NoPath(InvalidValue):
    code = "no_path"


def plan_around(
    checker: PathChecker,
    start: FloatArray,
    goal: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    timeout: float = 10.0,
    verify: Verify | None = None,
) -> FloatArray:
    """Vertices of a collision-free joint polyline from start to goal (rows): `verify`
    (the checker's path check of the vertices, unless given) has found nothing on it."""
    for where, q in (("the robot now", start), ("the target", goal)):
        hit = checker.configuration(q)
        if hit is not None:
            now = q is start
            raise NoPath(
                f"no path: at {where}, {hit.describe()}",
                code="collision",
                words=words(
                    "motion.collision_now" if now else "motion.collision_at_target",
                    part=hit.robot_part,
                    other=hit.other,
                ),
            )
    screen = Screen(checker.world, checker.robot, checker.margin, [start, goal], SEARCH_RESOLUTION)
    for widen, share in ATTEMPTS:
        low, high = lower, upper
        if widen is not None:
            low = np.maximum(lower, np.minimum(start, goal) - widen)
            high = np.minimum(upper, np.maximum(start, goal) + widen)
        found = _search(screen, start, goal, low, high, timeout * share)
        if found is None:
            continue
        vertices = shortcut(found, screen.motion)
        if (verify or checker.path)(vertices) is None:
            return vertices
    raise NoPath("no collision-free path found; move the robot or the obstacles and retry")


def _search(
    screen: Screen,
    start: FloatArray,
    goal: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    timeout: float,
) -> FloatArray | None:
    """RRT-Connect's path within the bounds, vertices as rows (None: none in time)."""
    n = start.size
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    info = setup.getSpaceInformation()

    setup.setStateValidityChecker(lambda state: screen.clear(_joints(state, n)))
    motions = _Motions(info, screen, n)  # held here while OMPL uses it
    info.setMotionValidator(motions)
    a, b = space.allocState(), space.allocState()
    for i in range(n):
        a[i], b[i] = float(start[i]), float(goal[i])
    setup.setStartAndGoalStates(a, b)
    setup.setPlanner(og.RRTConnect(info))
    if not setup.solve(timeout) or not setup.haveExactSolutionPath():
        return None
    path = setup.getSolutionPath()
    return np.array([_joints(path.getState(k), n) for k in range(path.getStateCount())])


def _joints(state: ob.State, n: int) -> FloatArray:
    return np.array([state[i] for i in range(n)])


class _Motions(ob.MotionValidator):  # type: ignore[misc]
    """OMPL's motion checks, answered by the screen a whole motion at a time."""

    def __init__(self, info: ob.SpaceInformation, screen: Screen, n: int) -> None:
        super().__init__(info)
        self.screen = screen
        self.n = n

    def checkMotion(self, a: ob.State, b: ob.State) -> bool:
        return self.screen.motion(_joints(a, self.n), _joints(b, self.n))
