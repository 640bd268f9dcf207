"""Real-time avoidance in the Cartesian jog QP: jogging straight at an obstacle stops at the
safety distance without contact; two robots driven at the same point keep apart."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.robotics.avoidance import SAFETY, AvoidanceConstraint
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.velocity import VelocityController
from openpendant.runtime.robotics.world import World

INFO = load_robot_info("ur5")
PERIOD = 0.01


def controller(world: World, robot: str) -> tuple[VelocityController, AvoidanceConstraint]:
    avoid = AvoidanceConstraint(world, robot)
    body = world.robot(robot)
    velocity = VelocityController(
        body.kinematics,
        np.array([j.max_velocity for j in INFO.joints]),
        np.array([j.max_acceleration for j in INFO.joints]),
        PERIOD,
        constraints=[avoid],
    )
    return velocity, avoid


def test_jogging_at_an_obstacle_stops_at_the_safety_distance() -> None:
    world = World()
    world.add_robot("r", INFO)
    kinematics = world.robot("r").kinematics
    q = np.array(INFO.home)
    tcp = kinematics.tcp(q).translation
    wall = SceneObject(
        shape="box", size=[0.05, 0.6, 0.6], pose={"position": [tcp[0] - 0.2, tcp[1], tcp[2]]}
    )
    world.set_objects({"wall": wall})
    velocity, avoid = controller(world, "r")
    twist = np.array([-0.2, 0.0, 0.0, 0.0, 0.0, 0.0])  # straight at the wall
    previous = np.zeros(INFO.dof)
    closest = np.inf
    for _ in range(400):  # 4 s: far longer than the 1 s it would take to reach the wall
        step = velocity.from_twist(q, twist, 0.25, previous)
        q = q + step.velocity * PERIOD
        previous = step.velocity
        contact = world.nearest("r", q)
        assert contact is not None
        closest = min(closest, contact.proximity.distance)
    assert closest >= SAFETY * 0.9
    assert closest < SAFETY * 2  # it did go up to it, and stopped there
    assert avoid.nearest is not None and avoid.nearest.proximity.other == "wall"


def test_two_robots_driven_at_the_same_point_keep_apart() -> None:
    world = World()
    world.add_robot("a", INFO, pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0])))
    facing = pin.SE3(pin.rpy.rpyToMatrix(0, 0, np.pi), np.array([-1.1, 0.0, 0.0]))
    world.add_robot("b", INFO, facing)
    goal = np.array([-0.55, 0.0, 0.35])  # midway, in the world
    robots = {name: controller(world, name) for name in ("a", "b")}
    q = {name: np.array(INFO.home) for name in robots}
    previous = {name: np.zeros(INFO.dof) for name in robots}
    closest = np.inf
    for _ in range(500):
        for name, (velocity, _) in robots.items():
            body = world.robot(name)
            body.place(q[name])
            tcp = body.world_base.act(body.kinematics.tcp(q[name]).translation)
            toward = body.world_base.rotation.T @ (goal - tcp)
            linear = (
                toward / max(np.linalg.norm(toward), 1e-9) * min(0.2, 2 * np.linalg.norm(toward))
            )
            step = velocity.from_twist(
                q[name], np.concatenate([linear, np.zeros(3)]), 0.25, previous[name]
            )
            q[name] = q[name] + step.velocity * PERIOD
            previous[name] = step.velocity
            body.place(q[name])
        contact = world.nearest("a", q["a"])
        assert contact is not None
        closest = min(closest, contact.proximity.distance)
    assert closest >= SAFETY * 0.9


def test_a_joint_jog_at_an_obstacle_slows_to_a_stop_and_moves_no_other_joint() -> None:
    world = World()
    world.add_robot("r", INFO)
    q = np.array(INFO.home)
    tcp = world.robot("r").kinematics.tcp(q).translation
    # A post beside the wrist, in the way of J1 turning positive.
    post = SceneObject(shape="cylinder", size=[0.04, 0.8], pose={"position": [0.0, 0.0, 0.4]})
    turned = pin.exp3(np.array([0.0, 0.0, 0.5])) @ tcp
    post.pose.position = [float(turned[0]), float(turned[1]), 0.4]
    world.set_objects({"post": post})
    velocity, _ = controller(world, "r")
    wanted = np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    previous = np.zeros(INFO.dof)
    start = q.copy()
    for _ in range(400):
        step = velocity.from_joint_velocity(q, wanted, 0.25, previous)
        assert np.all(step.velocity[1:] == 0.0)
        q = q + step.velocity * PERIOD
        previous = step.velocity
    contact = world.nearest("r", q)
    assert contact is not None and contact.proximity.other == "post"
    assert SAFETY * 0.9 <= contact.proximity.distance < SAFETY * 2
    assert q[0] > start[0] + 0.2  # it went most of the way first
