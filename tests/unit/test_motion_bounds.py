"""The cheap bounds the collision checks stand on: a pair's bound never overstates its exact
distance (nor a penetration's depth), a part's clearance is exact wherever it is near, each
part's travel bound holds for any joint step, and the path checker jumps to exactly the first
point where a room runs out."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.robotics.checker import PathChecker, _Travel
from openpendant.runtime.robotics.geometry import proximity
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.world import World

INFO = load_robot_info("ur5")
LOWER = np.maximum([j.lower for j in INFO.joints], -3.2)
UPPER = np.minimum([j.upper for j in INFO.joints], 3.2)
COLLISION_MESH = "package://example-robot-data/robots/ur_description/meshes/ur5/collision/"


def turned(rpy: tuple[float, float, float]) -> list[float]:
    x, y, z, w = pin.Quaternion(pin.rpy.rpyToMatrix(*rpy)).coeffs()
    return [float(x), float(y), float(z), float(w)]


def mixed_scene() -> World:
    """Every kind of obstacle, turned every which way, around a second robot."""
    objects = {
        "table": SceneObject(shape="box", size=[1.6, 1.6, 0.04], pose={"position": [0, 0, -0.02]}),
        "slab": SceneObject(
            shape="box",
            size=[0.3, 0.05, 0.4],
            pose={"position": [0.35, 0.2, 0.4], "orientation": turned((0.4, -0.3, 1.1))},
        ),
        "post": SceneObject(
            shape="cylinder",
            size=[0.04, 0.6],
            pose={"position": [-0.4, -0.3, 0.3], "orientation": turned((0.7, 0.2, 0.0))},
        ),
        "ball": SceneObject(shape="sphere", size=[0.08], pose={"position": [0.1, -0.45, 0.5]}),
        "part": SceneObject(
            shape="mesh",
            size=[1.0, 1.0, 1.0],
            mesh=COLLISION_MESH + "forearm.stl",
            pose={"position": [-0.2, 0.4, 0.3], "orientation": turned((0.0, 1.2, 0.3))},
        ),
    }
    world = World()
    world.add_robot("r", INFO)
    world.add_robot("other", INFO, pin.SE3(np.eye(3), np.array([1.1, 0.0, 0.0])))
    world.set_objects(objects)
    return world


def test_lower_bounds_never_overstate_a_distance_or_a_penetration() -> None:
    world = mixed_scene()
    rng = np.random.default_rng(5)
    inside = 0
    for _ in range(150):
        world.robot("other").place(rng.uniform(LOWER, UPPER))
        parts, others, bounds = world._pairs("r", rng.uniform(LOWER, UPPER))
        exact = np.array([[proximity(p.shape, o).distance for o in others] for p in parts])
        inside += int(np.sum(exact < 0))
        # Signed: a bound under a penetration's depth too, so the nearest pair stays nearest.
        assert np.all(bounds <= exact + 1e-6)
    assert inside > 20  # penetrations were tried


def test_a_part_clearance_is_exact_when_near_and_a_bound_when_not() -> None:
    world = mixed_scene()
    body = world.robot("r")
    rng = np.random.default_rng(6)
    within = 0.08
    exact_ones = 0
    for _ in range(100):
        q = rng.uniform(LOWER, UPPER)
        picked = np.sort(rng.choice(len(body.moving), 3, replace=False))
        clear = world.part_clearances("r", q, within, picked)
        for value, i in zip(clear, picked, strict=True):
            part = body.moving[i]
            others = world._others("r")
            nearest = min(proximity(part.shape, o).distance for o in others)
            assert value <= nearest + 1e-9
            if nearest < within:
                assert abs(value - nearest) < 1e-9
                exact_ones += 1
            else:
                assert value >= within - 1e-9 or value == nearest
    assert exact_ones > 50


def hull_points(world: World, part_index: int) -> np.ndarray[Any, Any]:
    part = world.robot("r").moving[part_index]
    shape = part.shape
    if shape.hull is None:  # a box: its corners
        half = np.array(shape.size) / 2
        local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    else:
        local = shape.hull[0]
    points: np.ndarray[Any, Any] = local @ shape.rotation.T + shape.translation
    return points


def test_part_travel_bounds_hold_for_any_joint_step() -> None:
    """No point of a part moves further than its bound says, for small steps and large."""
    world = mixed_scene()
    body = world.robot("r")
    bounds = body.part_reach_bounds()
    assert bounds.shape == (len(body.moving), INFO.dof)
    assert np.allclose(body.reach_bounds(), bounds.max(axis=0))
    rng = np.random.default_rng(8)
    tightest = np.inf
    for scale in (0.02, 0.3, 1.5):
        for _ in range(60):
            q = rng.uniform(LOWER, UPPER)
            dq = rng.normal(0.0, scale, INFO.dof)
            body.place(q)
            before = [hull_points(world, p) for p in range(len(body.moving))]
            # Along the straight joint line, the path (not just the ends) is bounded: check
            # the ends and the middle.
            for s in (0.5, 1.0):
                body.place(q + s * dq)
                for p, points in enumerate(before):
                    moved = float(np.max(np.linalg.norm(hull_points(world, p) - points, axis=1)))
                    allowed = float(bounds[p] @ np.abs(s * dq))
                    assert moved <= allowed + 1e-9
                    if allowed > 1e-3:
                        tightest = min(tightest, allowed / max(moved, 1e-12))
    assert tightest < 1.5  # the bounds are not loose everywhere


def test_the_checker_measures_where_a_room_is_first_used_up() -> None:
    rng = np.random.default_rng(9)
    samples = np.cumsum(rng.normal(0.0, 0.05, (40, 6)), axis=0)
    room_bounds = rng.uniform(0.0, 1.0, (7, 6))
    room_bounds[2] = 0.0  # a room no joint uses up
    bounds = room_bounds.max(axis=0)
    along = _Travel(samples, room_bounds, bounds)
    done = np.vstack((np.zeros(6), np.cumsum(np.abs(np.diff(samples, axis=0)), axis=0)))

    def joints_travelled(at: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        """Each joint's travel from the start to each point (rows)."""
        index = np.arange(len(done))
        return np.stack([np.interp(at, index, done[:, j]) for j in range(6)], axis=1)

    fine = np.linspace(0.0, along.end, 20001)
    travel = joints_travelled(fine) @ room_bounds.T
    for _ in range(20):
        ends = rng.uniform(0.0, 1.0, 7)
        first = along.first(ends)
        used = np.any(travel >= ends - 1e-12, axis=1)
        expected = fine[np.argmax(used)] if used.any() else np.inf
        if np.isfinite(first):
            assert np.allclose(
                along.rooms(first), joints_travelled(np.array([first]))[0] @ room_bounds.T
            )
        assert first == expected or abs(first - expected) <= along.end / 20000 + 1e-9
        # The resolution step: `distance` of the worst travel further on, or none left.
        at = float(rng.uniform(0.0, along.end))
        after = along.after(at, 0.05)
        start, end = joints_travelled(np.array([at, min(after, along.end)])) @ bounds
        if np.isfinite(after):
            assert abs(end - start - 0.05) < 1e-9
        else:
            assert end - start < 0.05


def test_a_dense_path_and_its_corners_are_checked_alike() -> None:
    """A trajectory's many samples along the lines between a few corners: the check finds
    the same plate on the dense path as on the corners, and the clear path clear."""
    plate = SceneObject(shape="box", size=[0.01, 0.6, 0.6], pose={"position": [-0.55, 0.0, 0.3]})
    world = World()
    world.add_robot("r", INFO)
    world.set_objects({"plate": plate})
    checker = PathChecker(world, "r")
    left = np.array([1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
    right = np.array([-1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
    over = np.array([0.0, -1.9, 1.0, -1.5, -1.57, 0.0])
    through = np.array([left, right])
    dense = np.vstack([left + s * (right - left) for s in np.linspace(0.0, 1.0, 3000)])
    for path in (through, dense):
        hit = checker.path(path)
        assert hit is not None and hit.other == "plate"
    around = np.array([left, over, right])
    if checker.path(around) is None:  # the corners clear: the dense samples too
        dense = np.vstack(
            [
                a + s * (b - a)
                for a, b in ((left, over), (over, right))
                for s in np.linspace(0, 1, 900)
            ]
        )
        assert checker.path(dense) is None
