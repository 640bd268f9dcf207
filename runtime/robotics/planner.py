"""Joint-space global planning around obstacles: OMPL's RRT-Connect with the world's
distance queries as the validity check, its path shortened, then proven collision-free by
the conservative path checker before anyone may execute it."""

from __future__ import annotations

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from runtime.interfaces.limits import FloatArray
from runtime.kit.errors import InvalidValue
from runtime.robotics.checker import PathChecker

ou.setLogLevel(ou.LogLevel.LOG_WARN)

VALIDITY_RESOLUTION = 0.002  # of the joint space extent (about 0.06 rad for a UR) between checks
ATTEMPTS = 3


class NoPath(InvalidValue):
    code = "no_path"


def plan_around(
    checker: PathChecker,
    start: FloatArray,
    goal: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    timeout: float = 10.0,
) -> FloatArray:
    """Vertices of a collision-free joint polyline from start to goal (rows)."""
    for where, q in (("the robot now", start), ("the target", goal)):
        hit = checker.configuration(q)
        if hit is not None:
            raise NoPath(f"no path: at {where}, {hit.describe()}", code="collision")
    n = start.size
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)

    def valid(state: ob.State) -> bool:
        q = np.array([state[i] for i in range(n)])
        return checker.configuration(q) is None

    setup.setStateValidityChecker(valid)
    setup.getSpaceInformation().setStateValidityCheckingResolution(VALIDITY_RESOLUTION)
    a, b = space.allocState(), space.allocState()
    for i in range(n):
        a[i], b[i] = float(start[i]), float(goal[i])
    setup.setStartAndGoalStates(a, b)
    setup.setPlanner(og.RRTConnect(setup.getSpaceInformation()))
    for _ in range(ATTEMPTS):
        setup.clear()
        if not setup.solve(timeout / ATTEMPTS) or not setup.haveExactSolutionPath():
            continue
        setup.simplifySolution()
        path = setup.getSolutionPath()
        vertices = np.array(
            [[path.getState(k)[i] for i in range(n)] for k in range(path.getStateCount())]
        )
        if checker.path(vertices) is None:
            return vertices
    raise NoPath("no collision-free path found; move the robot or the obstacles and retry")
