"""What was checked is what is executed: fast moves planned by the motion planner and run on
the simulated controller (the trajectory as the driver receives it) stay on the planned path,
on every simulated model and in both operational modes; a trajectory the controller cannot
follow as given is slowed along its path, never cut short joint by joint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from openpendant.runtime.bench.bench_path_fidelity import follow, linear, moves
from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import JointTrajectory, TrajectoryWaypoint
from openpendant.runtime.motion.executor import trajectory as as_trajectory
from openpendant.runtime.motion.moves import MovePlanner, Point
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.reference import Limits, TrajectoryReference
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.timing import TimedPath
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED
from openpendant.runtime.robotics.world import World


def planned_line(
    model: str, offset: list[float], tcp_cap: float | None = None
) -> tuple[MovePlanner, FloatArray, pin.SE3, pin.SE3, TimedPath]:
    """A fast linear move from the model's home by `offset`, planned: (the planner, home
    joints, the TCP there, the goal, the timed trajectory)."""
    info = load_robot_info(model)
    world = World()
    world.add_robot("r", info)
    planner = MovePlanner(world, "r", tcp_cap)
    home = np.array(info.home)
    here = planner.kinematics.tcp(home).copy()
    goal = pin.SE3(here.rotation, here.translation + np.array(offset))
    plan = planner.plan(linear(goal), home, [Point(None, goal)])
    assert plan.report.ok and plan.timed is not None, plan.report.message
    return planner, home, here, goal, plan.timed


def worst_off_line(planner: MovePlanner, here: pin.SE3, goal: pin.SE3, done: FloatArray) -> float:
    tcp = np.array([planner.kinematics.tcp(q).translation for q in done])
    return float(np.max(distances_to_polyline(np.array([here.translation, goal.translation]), tcp)))


def off_line(model: str, offset: list[float], tcp_cap: float | None) -> tuple[float, float]:
    """(worst distance of the executed TCP from the straight line, m; the plan's duration)."""
    planner, home, here, goal, timed = planned_line(model, offset, tcp_cap)
    done = follow(planner.info, home, as_trajectory(timed))
    assert np.linalg.norm(planner.kinematics.tcp(done[-1]).translation - goal.translation) < 1e-6
    return worst_off_line(planner, here, goal, done), timed.duration


def test_the_600_mm_linear_move_in_automatic_mode_stays_on_its_line() -> None:
    """The move that left its line by 69.6 mm (the reference's jerk passed the limit, the
    joints were handed to ruckig one by one)."""
    worst, _ = off_line("ur5", [0.0, 0.6, 0.0], None)
    assert worst < 1e-3, f"{worst * 1000:.2f} mm off the line"


@pytest.mark.parametrize(
    ("model", "offset"),
    [
        ("ur3", [0.0, 0.3, 0.0]),
        ("ur10", [0.5, 0.0, -0.3]),
        ("ur5e", [0.3, -0.3, 0.2]),
        ("panda", [0.0, 0.4, -0.2]),
    ],
)
def test_fast_linear_moves_of_every_model_stay_on_their_line(
    model: str, offset: list[float]
) -> None:
    worst, _ = off_line(model, offset, None)
    assert worst < 1e-3, f"{model}: {worst * 1000:.2f} mm off the line"


def test_a_linear_move_in_manual_mode_stays_on_its_line_and_is_slower() -> None:
    worst, manual = off_line("ur5", [0.0, 0.6, 0.0], MANUAL_TCP_SPEED)
    assert worst < 1e-3
    _, auto = off_line("ur5", [0.0, 0.6, 0.0], None)
    assert manual > 2.0 * auto  # 250 mm/s against up to about 900


def test_a_trajectory_past_the_jerk_limit_is_slowed_along_its_path() -> None:
    """Waypoints without accelerations: the controller estimates them, and the interpolated
    reference passes the jerk limit. It runs slower, on the same path, to its end."""
    planner, home, here, goal, timed = planned_line("ur5", [0.0, 0.6, 0.0])
    bare = JointTrajectory(
        waypoints=[
            TrajectoryWaypoint(time_from_start=float(t), position=list(p), velocity=list(v))
            for t, p, v in zip(
                timed.times[1:], timed.positions[1:], timed.velocities[1:], strict=True
            )
        ]
    )
    estimated = TrajectoryReference(timed.times, timed.positions, timed.velocities)
    assert estimated.peak_ratio(Limits.of(planner.info.joints)) > 1.0  # not followable as is
    done = follow(planner.info, home, bare)
    assert worst_off_line(planner, here, goal, done) < 1e-3
    assert len(done) * 0.002 > timed.duration * 1.05  # slower than planned


def test_the_planner_checks_its_trajectory_as_the_drivers_interpolate_it() -> None:
    planner, _, _, _, timed = planned_line("ur5", [0.0, 0.6, 0.0])
    assert timed.reference().peak_ratio(Limits.of(planner.info.joints)) <= 1.0


def test_a_driver_samples_the_reference_the_planner_checked() -> None:
    """A driver samples one time per cycle (`sample_with_acceleration`, from the segment's
    coefficients, kept between calls); the planner checks many at once (`sample_many`). Both
    are the same interpolation: at times in order, backwards and at waypoints, with and
    without the waypoints' velocities; at and past the end, the last waypoint at rest."""
    _, _, _, _, timed = planned_line("ur5", [0.0, 0.6, 0.0])
    hermite = timed.reference()
    straight = TrajectoryReference(timed.times, timed.positions, None)
    rng = np.random.default_rng(3)
    times = np.concatenate(
        [
            np.arange(0.0, timed.duration, 0.002),
            rng.uniform(0.0, timed.duration, 300),
            timed.times[:-1],
        ]
    )
    for reference in (hermite, straight):
        for t in times:
            p, v, a = reference.sample_with_acceleration(float(t))
            many = reference.sample_many(np.array([t]))
            assert np.allclose(p, many[0][0], rtol=0, atol=1e-12)
            # Summed in another order: the last digits differ (accelerations of a few rad/s²).
            assert np.allclose(v, many[1][0], rtol=0, atol=1e-10)
            assert np.allclose(a, many[2][0], rtol=0, atol=1e-8)
        for t in (timed.duration, timed.duration + 1.0):
            p, v, a = reference.sample_with_acceleration(t)
            assert np.array_equal(p, timed.positions[-1]) and not v.any() and not a.any()


def test_the_benchmarks_moves_stay_on_their_paths_and_the_monitor_never_fires() -> None:
    """A share of the `path_fidelity` benchmark's moves on the Panda (7 joints): linear,
    blended and joint moves within their bounds, the path monitor quiet on all of them."""
    outcomes = moves("panda", limit=2)
    kinds = {o.kind for o in outcomes}
    assert kinds == {"linear", "blend", "joint"}
    for o in outcomes:
        bound = 0.002 if o.kind == "joint" else 1e-3
        assert o.deviation < bound, o
        assert not o.monitor_fired, o
