"""The motion planner without processes: collision checking of paths (nothing passes
through a thin obstacle unseen), refusals name the colliding pair, planning around a cluttered
scene, straight TCP lines, and time-scaling within the joint limits."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.motion.models import MoveRequest
from openpendant.runtime.motion.moves import MovePlanner, Point
from openpendant.runtime.robotics.checker import PathChecker
from openpendant.runtime.robotics.geometry import proximity
from openpendant.runtime.robotics.paths import PathError, sample_tcp_path
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.timing import time_scale
from openpendant.runtime.robotics.world import World

INFO = load_robot_info("ur5")
# Left and right of the robot (a UR's base x axis points backwards), arm folded over the table.
LEFT = np.array([1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
RIGHT = np.array([-1.0, -1.0, 1.8, -2.37, -1.57, 0.0])


def cluttered() -> dict[str, SceneObject]:
    """A table under the robot and two posts in the way of a swing from left to right."""
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


def joint_move(**fields: Any) -> MoveRequest:
    return MoveRequest.model_validate(
        {"kind": "joint", "target": {"joints": list(RIGHT)}, **fields}
    )


def test_a_thin_obstacle_between_two_far_samples_is_found() -> None:
    """One segment swinging the arm by 2 rad: the 1 cm plate it crosses is still seen."""
    plate = SceneObject(shape="box", size=[0.01, 0.6, 0.6], pose={"position": [-0.55, 0.0, 0.3]})
    world = world_with({"plate": plate})
    checker = PathChecker(world, "r")
    assert checker.configuration(LEFT) is None
    assert checker.configuration(RIGHT) is None
    hit = checker.path(np.array([LEFT, RIGHT]))
    assert hit is not None
    assert hit.other == "plate"
    assert hit.robot_part.startswith("r/")


def test_a_colliding_move_is_refused_with_the_pair() -> None:
    world = world_with(cluttered())
    plan = MovePlanner(world, "r", None).plan(
        joint_move(avoid_obstacles=False), LEFT, [Point(RIGHT, None)]
    )
    assert not plan.report.ok
    assert plan.report.code == "collision"
    assert plan.report.collision is not None
    assert plan.report.collision.other in ("post_a", "post_b")
    assert plan.report.collision.robot_part.startswith("r/")
    assert plan.timed is None


def test_a_move_folding_the_arm_into_itself_is_refused_with_the_pair() -> None:
    world = world_with({})
    checker = PathChecker(world, "r")
    home = np.array(INFO.home)
    # The robot's own links at home and in the test poses are clear of each other.
    for q in (home, LEFT, RIGHT):
        assert checker.configuration(q) is None
    folded = np.array([0.0, -1.57, 3.0, 0.0, 0.0, 0.0])  # the wrist into the upper arm
    hit = checker.configuration(folded)
    assert hit is not None
    assert {hit.robot_part, hit.other} <= {
        f"r/{link}"
        for link in ("upper_arm_link", "wrist_2_link", "wrist_3_link", "wrist_1_link", "ee_link")
    }
    plan = MovePlanner(world, "r", None).plan(
        joint_move(avoid_obstacles=False), home, [Point(folded, None)]
    )
    assert not plan.report.ok and plan.report.code == "collision"
    assert plan.report.collision is not None
    assert plan.report.collision.other.startswith("r/")
    # The upper arm swung down through the base.
    down = np.array([0.0, 0.8, 0.0, -1.57, -1.57, 0.0])
    hit = checker.configuration(down)
    assert hit is not None and "r/base_link" in (hit.robot_part, hit.other)
    # Both ends clear, the elbow folding through itself between them: found on the way.
    start, end = LEFT.copy(), LEFT.copy()
    start[2], end[2] = 2.0, 4.0
    assert checker.configuration(start) is None and checker.configuration(end) is None
    hit = checker.path(np.array([start, end]))
    assert hit is not None and hit.robot_part.startswith("r/") and hit.other.startswith("r/")


def test_self_pair_bounds_bound_how_far_a_joint_step_moves_one_link_from_the_other() -> None:
    world = world_with({})
    body = world.robot("r")
    bounds = body.self_pair_bounds
    assert bounds.shape == (len(body.self_pairs), 6)
    # The base joint turns every link but the base link as one.
    for p, (a, b) in enumerate(body.self_pairs):
        assert (bounds[p, 0] > 0) == (0 in (a.joint, b.joint))

    def exact() -> np.ndarray[Any, Any]:
        return np.array([proximity(a.shape, b.shape).distance for a, b in body.self_pairs])

    rng = np.random.default_rng(7)
    lower = np.array([j.lower for j in INFO.joints])
    upper = np.array([j.upper for j in INFO.joints])
    for _ in range(200):
        q = rng.uniform(np.maximum(lower, -3.0), np.minimum(upper, 3.0))
        dq = rng.normal(0.0, 0.05, 6)
        body.place(q)
        before = exact()
        # The distances the checker works from never overstate the exact ones.
        assert np.all(world.self_clearances("r")[1] <= before + 1e-9)
        body.place(q + dq)
        assert np.all(np.abs(exact() - before) <= bounds @ np.abs(dq) + 1e-5)


def test_no_collision_dense_sampling_finds_is_missed_by_the_checker() -> None:
    """Random joint moves through the cluttered scene, each cut short where 400 evenly spaced
    samples first find the robot touching itself or anything else: the move ends just
    touching, and the path check still finds the collision."""
    world = world_with(cluttered())
    checker = PathChecker(world, "r")
    rng = np.random.default_rng(11)
    lower = np.array([j.lower for j in INFO.joints])
    upper = np.array([j.upper for j in INFO.joints])

    def touching(q: np.ndarray[Any, Any]) -> bool:
        outer = world.nearest("r", q)
        inner, _ = world.self_clearances("r")
        return inner is not None or (outer is not None and outer.proximity.distance <= 0)

    missed, tried = [], 0
    while tried < 25:
        a = rng.uniform(np.maximum(lower, -3.2), np.minimum(upper, 3.2))
        b = rng.uniform(np.maximum(lower, -3.2), np.minimum(upper, 3.2))
        if touching(a):
            continue
        first = next((s for s in np.linspace(0.0, 1.0, 400) if touching(a + s * (b - a))), None)
        if first is None:
            continue
        tried += 1
        end = a + first * (b - a)
        if checker.path(np.array([a, end])) is None:
            missed.append((a, end))
    assert missed == []


def test_the_planner_finds_a_collision_free_path_in_a_cluttered_scene() -> None:
    world = world_with(cluttered())
    plan = MovePlanner(world, "r", None).plan(joint_move(), LEFT, [Point(RIGHT, None)])
    assert plan.report.ok, plan.report.message
    assert plan.report.planned_around
    assert plan.timed is not None
    assert np.allclose(plan.timed.positions[-1], RIGHT)
    # Every setpoint, and everything between them, is clear of the table and the posts.
    for q in plan.timed.positions:
        contact = world.nearest("r", q)
        assert contact is not None
        assert contact.proximity.distance > 0
    assert PathChecker(world, "r").path(plan.timed.positions) is None


def test_a_linear_path_stays_on_the_line_and_within_the_limits() -> None:
    world = world_with({})
    kinematics = world.robot("r").kinematics
    start = np.array(INFO.home)
    here = kinematics.tcp(start).copy()
    goal = pin.SE3(here.rotation, here.translation + np.array([0.15, 0.1, -0.1]))
    samples = sample_tcp_path(kinematics, start, [here, goal], [])
    timed = time_scale(samples, INFO, speed=1.0, acceleration=1.0)
    direction = (goal.translation - here.translation) / np.linalg.norm(
        goal.translation - here.translation
    )
    for q in timed.positions:
        offset = kinematics.tcp(q).translation - here.translation
        assert np.linalg.norm(np.cross(offset, direction)) < 0.5e-3
    assert np.linalg.norm(kinematics.tcp(timed.positions[-1]).translation - goal.translation) < 1e-7
    dt = np.diff(timed.times)[:, None]
    velocity = np.diff(timed.positions, axis=0) / dt
    limits = np.array([j.max_velocity for j in INFO.joints])
    assert np.all(np.abs(velocity) <= limits * (1 + 1e-9))
    acceleration = np.diff(timed.velocities, axis=0) / dt
    assert np.all(np.abs(acceleration) <= np.array([j.max_acceleration for j in INFO.joints]))


def test_a_line_out_of_reach_fails_before_any_motion() -> None:
    world = world_with({})
    kinematics = world.robot("r").kinematics
    start = np.array(INFO.home)
    here = kinematics.tcp(start).copy()
    far = pin.SE3(here.rotation, here.translation + np.array([-1.5, 0.0, 0.0]))
    with pytest.raises(PathError) as err:
        sample_tcp_path(kinematics, start, [here, far], [])
    # Said as what it is: the target is out of reach (it had been called a singularity).
    assert err.value.code == "unreachable"
    assert "out of reach" in err.value.message


def test_a_joint_move_to_a_pose_takes_another_solution_where_the_nearest_collides() -> None:
    """The pose LEFT's TCP is at, from LEFT: its own joints would put the elbow in a ball
    placed there; elbow down (or another branch) reaches the same pose clear of it."""
    kinematics = MovePlanner(world_with({}), "r", None).kinematics
    target = kinematics.tcp(LEFT).copy()
    model, data = kinematics.model, kinematics.data
    q = pin.neutral(model)
    q[kinematics.order] = LEFT
    pin.framesForwardKinematics(model, data, q)
    base = data.oMf[kinematics.base_frame]
    elbow = base.actInv(data.oMf[model.getFrameId("forearm_link")]).translation
    ball = SceneObject(shape="sphere", size=[0.06], pose={"position": elbow.tolist()})
    world = world_with({"ball": ball})
    planner = MovePlanner(world, "r", None)
    assert PathChecker(world, "r").configuration(LEFT) is not None  # the nearest collides
    request = MoveRequest.model_validate(
        {"kind": "joint", "target": {"pose": {"position": [0, 0, 0]}}}
    )
    start = np.array([1.0, -1.57, 0.5, -1.0, -1.57, 0.0])  # clear of it; reaches LEFT from here
    assert np.allclose(kinematics.inverse(target, start), LEFT, atol=1e-3)
    plan = planner.plan(request, start, [Point(None, target)])
    assert plan.report.ok, plan.report
    goal = np.array(plan.report.goal)
    assert not np.allclose(goal, LEFT, atol=1e-3)
    reached = kinematics.tcp(goal)
    assert np.allclose(reached.translation, target.translation, atol=1e-6)
    assert np.allclose(reached.rotation, target.rotation, atol=1e-6)
