"""Motion figures, in-process on one core: inverse kinematics, a full-robot distance query
against a 10-object scene, one avoidance QP step (distances, Jacobians and the QP) beside
PyRI's baseline (unconstrained least squares, scipy lsq_linear, joint speed bounds only), and
planning around the posts of a cluttered scene."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from scipy.optimize import lsq_linear

from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick
from openpendant.runtime.interfaces.scene import SceneObject
from openpendant.runtime.motion.models import MoveRequest
from openpendant.runtime.motion.moves import MovePlanner, Point
from openpendant.runtime.robotics.avoidance import AvoidanceConstraint
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.velocity import VelocityController
from openpendant.runtime.robotics.world import World

FIGURES = (
    "ik_median",
    "ik_p99",
    "collision_distance_scene",
    "avoidance_qp_step_p99",
    "avoidance_qp_step_p50",
    "baseline_lsq_jog_step_p99",
    "plan_cluttered_median",
)
INFO = load_robot_info("ur5")
LEFT = np.array([1.0, -1.0, 1.8, -2.37, -1.57, 0.0])
RIGHT = np.array([-1.0, -1.0, 1.8, -2.37, -1.57, 0.0])


def scene(count: int = 10) -> dict[str, SceneObject]:
    """A table, two posts and boxes around the robot: `count` objects in all."""
    objects = {
        "table": SceneObject(shape="box", size=[1.6, 1.6, 0.04], pose={"position": [0, 0, -0.02]}),
        "post_a": SceneObject(
            shape="cylinder", size=[0.04, 0.5], pose={"position": [-0.5, 0.05, 0.25]}
        ),
        "post_b": SceneObject(
            shape="cylinder", size=[0.04, 0.5], pose={"position": [-0.4, -0.3, 0.25]}
        ),
    }
    for k in range(count - len(objects)):
        angle = 2 * np.pi * k / max(1, count - 3)
        position = [0.75 * np.cos(angle), 0.75 * np.sin(angle), 0.1 + 0.05 * k]
        objects[f"box_{k}"] = SceneObject(
            shape="box", size=[0.1, 0.1, 0.2], pose={"position": position}
        )
    return objects


def world(count: int = 10) -> World:
    w = World()
    w.add_robot("robot", INFO)
    w.set_objects(scene(count))
    return w


def ik_times(samples: int) -> list[float]:
    kinematics = Kinematics(INFO)
    rng = np.random.default_rng(0)
    lower, upper = np.maximum(kinematics.lower, -np.pi), np.minimum(kinematics.upper, np.pi)
    times = []
    for _ in range(samples):
        q = rng.uniform(lower, upper)
        target = kinematics.tcp(q).copy()
        seed = np.clip(q + rng.uniform(-0.3, 0.3, q.size), kinematics.lower, kinematics.upper)
        started = time.perf_counter()
        kinematics.inverse(target, seed)
        times.append((time.perf_counter() - started) * 1000)
    return times


def random_configurations(w: World, count: int) -> list[np.ndarray[Any, Any]]:
    """Configurations clear of the scene, near the home pose."""
    rng = np.random.default_rng(1)
    found = []
    for _ in range(100 * count):
        q = np.array(INFO.home) + rng.uniform(-0.8, 0.8, INFO.dof)
        contact = w.nearest("robot", q)
        if contact is not None and contact.proximity.distance > 0.01:
            found.append(q)
            if len(found) == count:
                return found
    raise RuntimeError("the scene leaves too little room for the robot")


def distance_times(w: World, configurations: list[np.ndarray[Any, Any]]) -> list[float]:
    times = []
    for q in configurations:
        started = time.perf_counter()
        w.nearest("robot", q)
        times.append((time.perf_counter() - started) * 1000)
    return times


def jog_step_times(
    w: World, configurations: list[np.ndarray[Any, Any]]
) -> tuple[list[float], list[float], int]:
    """One avoidance QP step and one baseline step, per configuration."""
    kinematics = w.robot("robot").kinematics
    v_max = np.array([j.max_velocity for j in INFO.joints])
    avoid = AvoidanceConstraint(w, "robot")
    controller = VelocityController(
        kinematics, v_max, np.array([j.max_acceleration for j in INFO.joints]), 0.01, [avoid]
    )
    twist = np.array([0.1, 0.05, -0.1, 0.0, 0.0, 0.2])
    ours, baseline, constrained = [], [], 0
    for q in configurations:
        started = time.perf_counter()
        controller.from_twist(q, twist, 0.25, np.zeros(INFO.dof))
        ours.append((time.perf_counter() - started) * 1000)
        constrained += avoid.nearest is not None
        started = time.perf_counter()
        lsq_linear(kinematics.jacobian(q), twist, bounds=(-v_max, v_max))
        baseline.append((time.perf_counter() - started) * 1000)
    return ours, baseline, constrained


def plan_times(runs: int) -> list[float]:
    w = world(3)
    planner = MovePlanner(w, "robot", None)
    request = MoveRequest.model_validate({"kind": "joint", "target": {"joints": list(RIGHT)}})
    times = []
    for _ in range(runs):
        started = time.perf_counter()
        plan = planner.plan(request, LEFT, [Point(RIGHT, None)])
        if not plan.report.ok or not plan.report.planned_around:
            raise RuntimeError(f"the cluttered plan failed: {plan.report.message}")
        times.append(time.perf_counter() - started)
    return times


def run() -> list[Figure]:
    w = world(10)
    configurations = random_configurations(w, 200 if quick() else 2000)
    ik = ik_times(200 if quick() else 2000)
    distances = distance_times(w, configurations)
    ours, baseline, constrained = jog_step_times(w, configurations)
    plans = plan_times(3 if quick() else 15)
    scene_details = {"robot": "ur5", "objects": 10, "samples": len(configurations)}
    return [
        Figure(
            "ik_median",
            percentile(ik, 50),
            "ms",
            "≤ 0.2 ms",
            percentile(ik, 50) <= 0.2,
            {"samples": len(ik), "seed": "the target's joints ± 0.3 rad (the current pose)"},
        ),
        Figure("ik_p99", percentile(ik, 99), "ms"),
        Figure(
            "collision_distance_scene",
            percentile(distances, 50),
            "ms",
            details={**scene_details, "p99": percentile(distances, 99)},
        ),
        Figure(
            "avoidance_qp_step_p99",
            percentile(ours, 99),
            "ms",
            "≤ 1 ms",
            percentile(ours, 99) <= 1.0,
            {**scene_details, "steps_with_constraints": constrained},
        ),
        Figure("avoidance_qp_step_p50", percentile(ours, 50), "ms"),
        Figure(
            "baseline_lsq_jog_step_p99",
            percentile(baseline, 99),
            "ms",
            details={
                "p50": percentile(baseline, 50),
                "measured": "Jacobian + scipy lsq_linear with joint speed bounds, no "
                "collision constraints (PyRI's jog step)",
            },
        ),
        Figure(
            "plan_cluttered_median",
            percentile(plans, 50),
            "s",
            "≤ 0.1 s",
            percentile(plans, 50) <= 0.1,
            details={
                "runs": len(plans),
                "scene": "table and two posts",
                "planner": "OMPL RRTConnect",
            },
        ),
    ]
