"""Path fidelity: fast moves planned by the motion service's planner in automatic mode (no
TCP cap) at full speed and acceleration, sent to the simulated controller as the driver
receives them (the trajectory through its JSON and its limit checks), and followed there
at 500 Hz; the deviation is measured on the controller's own setpoints against the path
that was planned and collision-checked. On every simulated model: linear moves of 0.2-0.8 m
in several directions (one as far out as the arm reaches), paths blended through 4
waypoints, and joint moves. The UR driver's figure is in `bench_ur` (through the emulator)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import quick
from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    JointTrajectory,
    OperationalMode,
    RobotInfo,
)
from openpendant.runtime.kit.settings import MotionSettings
from openpendant.runtime.motion.executor import trajectory as as_trajectory
from openpendant.runtime.motion.models import MoveRequest
from openpendant.runtime.motion.moves import MovePlanner, Point
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.path_monitor import PathDeviation, PathMonitor
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.timing import TimedPath
from openpendant.runtime.robotics.world import World

FIGURES = (
    "path_deviation_linear_max_mm",
    "path_deviation_blend_max_mm",
    "path_deviation_joint_max_rad",
)
MODELS = ("ur3", "ur5", "ur10", "ur5e", "panda")
_DEFAULTS = MotionSettings()
TOLERANCES = {
    "tolerance": _DEFAULTS.path_tolerance,
    "joint_tolerance": _DEFAULTS.joint_path_tolerance,
}
CYCLE = 0.002  # the simulated controller's
DIRECTIONS = np.array(
    [[0, 1, 0], [1, 0, 0], [0, 0, 1], [1, 1, 0], [-1, 0, -0.5], [0, -1, 0.5], [1, -1, -1]],
    dtype=float,
)
LENGTHS = (0.8, 0.6, 0.45, 0.3, 0.2)  # m: the longest that plans is taken
JOINT_OFFSETS = np.array(
    [[1.2, -0.4, 0.5, 0.3, -0.3, 0.8, 0.4], [-1.0, 0.3, -0.6, -0.5, 0.6, -1.0, -0.5],
     [0.6, 0.5, 0.4, -0.8, -0.4, 1.5, 0.9], [-1.5, -0.2, 0.3, 0.6, 1.0, 0.4, -1.2]]
)  # fmt: skip


@dataclass
class Outcome:
    """One move: its kind, the worst deviation (m, or rad for joint moves) and how long."""

    kind: str
    deviation: float
    duration: float
    description: str
    monitor_fired: bool  # the motion service's path monitor, at its default tolerances


def linear(pose: pin.SE3) -> MoveRequest:
    return MoveRequest.model_validate(
        {"kind": "linear", "target": {"pose": _pose(pose)}, "speed": 1, "acceleration": 1}
    )


def _pose(pose: pin.SE3) -> dict[str, list[float]]:
    q = pin.Quaternion(pose.rotation)
    return {"position": pose.translation.tolist(), "orientation": [q.x, q.y, q.z, q.w]}


def follow(info: RobotInfo, start: FloatArray, jt: JointTrajectory) -> FloatArray:
    """The simulated controller's setpoints (joint positions) while it runs `jt` from
    `start` in automatic mode, the trajectory taken as the driver takes it."""
    from openpendant.device_drivers.sim_robot.core import SimCore

    received = JointTrajectory.model_validate_json(jt.model_dump_json())
    checked = JointLimitChecker(info).trajectory(received, start)
    core = SimCore(info, Kinematics(info), history=200_000)
    core.tracker.place(start)
    core.operational_mode = OperationalMode.auto
    core.enable()
    core.set_mode(CommandMode.trajectory)
    core.start_trajectory(checked)
    now, limit = 0.0, checked.duration * 3 + 1.0
    while core.trajectory is not None and now < limit:
        now += CYCLE
        core.step(now)
    if core.trajectory is not None or core.error:
        raise RuntimeError(f"the simulated {info.model} did not finish: {core.error_message}")
    return np.array([s.position for s in core.setpoints])


def moves(model: str, limit: int | None = None) -> list[Outcome]:
    """The moves on one model; `limit`: at most that many of each kind."""
    if limit is None and quick():
        limit = 2
    info = load_robot_info(model)
    world = World()
    world.add_robot("r", info)
    planner = MovePlanner(world, "r", None)  # automatic mode: no TCP cap
    kinematics = planner.kinematics
    home = np.array(info.home)
    here = kinematics.tcp(home).copy()
    outcomes: list[Outcome] = []

    def run(kind: str, request: MoveRequest, points: list[Point], what: str) -> bool:
        plan = planner.plan(request, home, points)
        if not plan.report.ok or plan.timed is None:
            return False
        done = follow(info, home, as_trajectory(plan.timed))
        goal = plan.timed.positions[-1]
        monitor = PathMonitor(kinematics, plan.timed.positions, **TOLERANCES)
        try:
            for q in done[::5]:  # every 10 ms, about as often as it watches
                monitor.check(q)
            fired = False
        except PathDeviation:
            fired = True
        if kind == "joint":  # the straight joint line that was checked
            deviation = float(np.max(distances_to_polyline(np.array([home, goal]), done)))
        else:
            actual = np.array([kinematics.tcp(q).translation for q in done])
            if kind == "linear":  # the straight line itself
                path = np.array([here.translation, kinematics.tcp(goal).translation])
            else:  # the planned path as the drivers interpolate it, densely
                reference = plan.timed.reference()
                dense = reference.sample_many(np.arange(0.0, reference.duration, CYCLE / 2))[0]
                path = np.array([kinematics.tcp(q).translation for q in [*dense, goal]])
            deviation = float(np.max(distances_to_polyline(path, actual)))
        outcomes.append(Outcome(kind, deviation, plan.timed.duration, what, fired))
        return True

    for candidates in linear_goals(here, limit):
        for goal, what in candidates:
            if run("linear", linear(goal), [Point(None, goal)], what):
                break
    for k, size in enumerate((0.15, 0.25, 0.2, 0.3)[:limit]):
        corners = _square(here, size, k)
        request = MoveRequest.model_validate(
            {
                "kind": "path",
                "waypoints": [{"pose": _pose(c), "blend": size / 3} for c in corners],
                "speed": 1,
                "acceleration": 1,
            }
        )
        points = [Point(None, c, size / 3) for c in corners]
        run("blend", request, points, f"4 waypoints, {size} m square, blend {size / 3:.2f} m")
    for offset in JOINT_OFFSETS[:limit]:
        goal = np.clip(home + offset[: info.dof], kinematics.lower, kinematics.upper)
        request = MoveRequest.model_validate(
            {"kind": "joint", "target": {"joints": goal.tolist()}, "speed": 1, "acceleration": 1}
        )
        run("joint", request, [Point(goal, None)], f"joints by {offset[: info.dof].round(1)}")
    return outcomes


def linear_goals(here: pin.SE3, limit: int | None) -> list[list[tuple[pin.SE3, str]]]:
    """The linear moves from `here`, each as its candidate goals, longest first (the first
    that plans is the move): along each direction, then outwards from the base as far as
    the arm reaches."""
    moves = []
    for d in DIRECTIONS[:limit]:
        d = d / np.linalg.norm(d)
        moves.append(
            [
                (
                    pin.SE3(here.rotation, here.translation + length * d),
                    f"{length} m along {d.round(2)}",
                )
                for length in LENGTHS
            ]
        )
    radial = np.array([here.translation[0], here.translation[1], 0.0])
    radial /= np.linalg.norm(radial)
    moves.append(
        [
            (
                pin.SE3(here.rotation, here.translation + length * radial),
                f"{length:.2f} m out to the edge",
            )
            for length in np.linspace(0.8, 0.1, 15)
        ]
    )
    return moves


def linear_plans(
    planner: MovePlanner, start: FloatArray, limit: int | None = None
) -> list[tuple[str, pin.SE3, TimedPath]]:
    """The linear set from `start` as `moves` plans it: each move's description, goal and
    timed path."""
    here = planner.kinematics.tcp(start)
    plans = []
    for candidates in linear_goals(here, limit):
        for goal, what in candidates:
            plan = planner.plan(linear(goal), start, [Point(None, goal)])
            if plan.report.ok and plan.timed is not None:
                plans.append((what, goal, plan.timed))
                break
    return plans


def _square(here: pin.SE3, size: float, turn: int) -> list[pin.SE3]:
    """Four corners of a square around the TCP, in a plane tilted by `turn`."""
    angle = turn * np.pi / 5
    u = np.array([np.cos(angle), np.sin(angle), 0.0])
    w = np.array([0.0, 0.0, 1.0]) if turn % 2 == 0 else np.array([-np.sin(angle), np.cos(angle), 0])
    offsets = [size * u, size * (u + w), size * w, np.zeros(3)]
    return [pin.SE3(here.rotation, here.translation + o - size * (u + w) / 2) for o in offsets]


def run() -> list[Figure]:
    outcomes: dict[str, list[Outcome]] = {}
    for model in MODELS[:2] if quick() else MODELS:
        outcomes[model] = moves(model)

    def worst(kind: str) -> tuple[float, dict[str, object]]:
        per_model = {
            m: max((o.deviation for o in found if o.kind == kind), default=float("nan"))
            for m, found in outcomes.items()
        }
        counts = {m: sum(o.kind == kind for o in found) for m, found in outcomes.items()}
        return max(per_model.values()), {"per_model": per_model, "moves": counts}

    linear_max, linear_details = worst("linear")
    blend_max, blend_details = worst("blend")
    joint_max, joint_details = worst("joint")
    common = {
        "mode": "automatic, speed 1, acceleration 1",
        "measured": "simulated controller setpoints at 500 Hz vs the planned path",
        "moves_per_model": {m: len(found) for m, found in outcomes.items()},
        "path_monitor_fired": sum(o.monitor_fired for found in outcomes.values() for o in found),
    }
    return [
        Figure(
            "path_deviation_linear_max_mm",
            linear_max * 1000,
            "mm",
            "≤ 1 mm",
            linear_max * 1000 <= 1.0,
            {**common, **linear_details, "per_model": _mm(linear_details["per_model"])},
        ),
        Figure(
            "path_deviation_blend_max_mm",
            blend_max * 1000,
            "mm",
            "≤ 1 mm",
            blend_max * 1000 <= 1.0,
            {**common, **blend_details, "per_model": _mm(blend_details["per_model"])},
        ),
        Figure(
            "path_deviation_joint_max_rad",
            joint_max,
            "rad",
            "≤ 0.002 rad",
            joint_max <= 0.002,
            {**common, **joint_details},
        ),
    ]


def _mm(values: object) -> dict[str, float]:
    assert isinstance(values, dict)
    return {k: round(v * 1000, 4) for k, v in values.items()}
