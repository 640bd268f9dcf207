"""Planning around obstacles: the quick screen the search uses never lets through what the
path check refuses, shortcutting only ever puts in lines its check accepts, a path the check
refuses is searched for again, and a target nothing reaches is refused with a clear error."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.robotics.checker import PathChecker
from openpendant.runtime.robotics.planner import NoPath, plan_around
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.screen import Screen
from openpendant.runtime.robotics.shortcut import shortcut
from openpendant.runtime.robotics.world import World

INFO = load_robot_info("ur5")
LEFT = np.array([1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
RIGHT = np.array([-1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
LOWER = np.array([j.lower for j in INFO.joints])
UPPER = np.array([j.upper for j in INFO.joints])


def posts() -> dict[str, SceneObject]:
    return {
        "table": SceneObject(shape="box", size=[1.6, 1.6, 0.04], pose={"position": [0, 0, -0.02]}),
        "post_a": SceneObject(
            shape="cylinder", size=[0.04, 0.5], pose={"position": [-0.5, 0.05, 0.25]}
        ),
        "post_b": SceneObject(
            shape="cylinder", size=[0.04, 0.5], pose={"position": [-0.4, -0.3, 0.25]}
        ),
    }


def world_with(objects: dict[str, SceneObject]) -> World:
    world = World()
    world.add_robot("r", INFO)
    world.set_objects(objects)
    return world


def test_the_screen_never_clears_what_the_path_check_refuses() -> None:
    """Scene, another robot, a gripper carried on the TCP and the robot's own links."""
    objects = {
        **posts(),
        "ball": SceneObject(shape="sphere", size=[0.1], pose={"position": [0.3, 0.3, 0.45]}),
        "gripper": SceneObject(
            shape="box", size=[0.08, 0.08, 0.04], pose={"position": [0, 0, 0.02]}, attached_to="r"
        ),
    }
    world = World()
    world.add_robot("r", INFO)
    other = world.add_robot("other", INFO)
    other.set_base(pin.SE3(np.eye(3), np.array([1.0, 0.2, 0.0])))
    world.set_objects(objects)
    margin = 0.01
    checker = PathChecker(world, "r", margin)
    assert checker.configuration(LEFT) is None and checker.configuration(RIGHT) is None
    screen = Screen(world, "r", margin, [LEFT, RIGHT], 0.05)
    rng = np.random.default_rng(4)
    refused = 0
    for _ in range(600):
        q = rng.uniform(np.maximum(LOWER, -3.2), np.minimum(UPPER, 3.2))
        hit = checker.configuration(q)
        if hit is not None:
            refused += 1
            assert not screen.clear(q), hit.describe()
            assert not screen.motion(LEFT, q)  # a line ending in a collision is no line
    assert refused > 100
    assert screen.clear(LEFT) and screen.clear(RIGHT)


def test_shortcutting_puts_in_only_lines_its_check_accepts() -> None:
    """In the plane, round a square: the shortened path has fewer corners, is shorter, and
    every line of it is one the check accepted."""
    low, high = np.array([0.4, -0.5]), np.array([0.6, 0.5])

    def blocked(p: np.ndarray[Any, Any]) -> bool:
        return bool(np.all(p > low) and np.all(p < high))

    asked: set[tuple[float, ...]] = set()

    def clear(a: np.ndarray[Any, Any], b: np.ndarray[Any, Any]) -> bool:
        ok = not any(blocked(a + s * (b - a)) for s in np.linspace(0.0, 1.0, 400))
        if ok:
            asked.add((*a, *b))
        return ok

    rng = np.random.default_rng(3)
    # A wandering path round the square (its corners clear of it, and each line too).
    corners = [np.array([0.0, 0.0])]
    for x in np.linspace(0.05, 1.0, 30):
        y = 0.7 + rng.uniform(-0.1, 0.1) if 0.2 < x < 0.8 else rng.uniform(-0.2, 0.2)
        corners.append(np.array([x, y]))
    corners.append(np.array([1.0, 0.0]))
    path = np.array(corners)
    assert all(clear(a, b) for a, b in itertools.pairwise(path))
    short = shortcut(path, clear)
    assert np.array_equal(short[0], path[0]) and np.array_equal(short[-1], path[-1])
    assert len(short) < len(path) / 4

    def length(p: np.ndarray[Any, Any]) -> float:
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())

    assert length(short) < length(path) * 0.9
    for a, b in itertools.pairwise(short):
        assert (*a, *b) in asked  # a line the check was asked about, and accepted


def test_a_path_the_check_refuses_is_searched_for_again() -> None:
    world = world_with(posts())
    checker = PathChecker(world, "r", 0.005)
    seen: list[np.ndarray[Any, Any]] = []

    def verify(vertices: np.ndarray[Any, Any]) -> Any:
        seen.append(vertices)
        if len(seen) == 1:
            return checker.path(np.array([LEFT, RIGHT]))  # a collision: not this one
        return checker.path(vertices)

    vertices = plan_around(checker, LEFT, RIGHT, LOWER, UPPER, verify=verify)
    assert len(seen) == 2 and vertices is seen[1]
    assert np.array_equal(vertices[0], LEFT) and np.array_equal(vertices[-1], RIGHT)
    assert checker.path(vertices) is None

    def never(vertices: np.ndarray[Any, Any]) -> Any:
        return checker.path(np.array([LEFT, RIGHT]))

    with pytest.raises(NoPath):
        plan_around(checker, LEFT, RIGHT, LOWER, UPPER, timeout=2.0, verify=never)


def test_a_target_no_path_reaches_is_refused_with_a_clear_error() -> None:
    world = world_with(posts())
    checker = PathChecker(world, "r", 0.005)
    # Only the base may turn: the posts stand in the way whichever way it turns.
    low, high = np.minimum(LEFT, RIGHT) - 1e-3, np.maximum(LEFT, RIGHT) + 1e-3
    low[0], high[0] = -np.pi, np.pi
    with pytest.raises(NoPath) as refused:
        plan_around(checker, LEFT, RIGHT, low, high, timeout=1.0)
    assert refused.value.code == "no_path"
    assert "no collision-free path" in refused.value.message
    # A target in a post: said at once, naming it.
    inside = RIGHT.copy()
    inside[1] = 0.2
    assert checker.configuration(inside) is not None
    with pytest.raises(NoPath) as refused:
        plan_around(checker, LEFT, inside, LOWER, UPPER)
    assert refused.value.code == "collision"
    assert "at the target" in refused.value.message
