"""The simulated controller, stepped deterministically (no threads, no clock)."""

from __future__ import annotations

import asyncio
import itertools
import math
import threading
from typing import Any

import numpy as np
import pytest

from openpendant.device_drivers.sim_robot.core import CYCLE, SimCore
from openpendant.device_drivers.sim_robot.driver import SimRobot
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    JogJointCommand,
    JointTrajectory,
    PositionCommand,
    RobotInfo,
    TrajectoryState,
    TrajectoryWaypoint,
)
from openpendant.runtime.kit.errors import InvalidValue, RobotError
from openpendant.runtime.robotics.joint_move import plan_joint_move
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.tracker import JointTracker


@pytest.fixture(scope="module")
def ur5() -> RobotInfo:
    return load_robot_info("ur5")


@pytest.fixture
def core(ur5: RobotInfo) -> SimCore:
    c = SimCore(ur5, Kinematics(ur5))
    c.enable()
    return c


class Clock:
    def __init__(self, core: SimCore) -> None:
        self.core = core
        self.now = 0.0

    def run(self, seconds: float, each: object = None) -> None:
        for _ in range(round(seconds / CYCLE)):
            self.now += CYCLE
            if callable(each):
                each(self.now)
            self.core.step(self.now)


def assert_within_limits(core: SimCore) -> None:
    """Every recorded setpoint respects position, velocity and acceleration limits."""
    info = core.info
    lower = np.array([j.lower for j in info.joints])
    upper = np.array([j.upper for j in info.joints])
    vmax = np.array([j.max_velocity for j in info.joints])
    amax = np.array([j.max_acceleration for j in info.joints])
    for s in core.setpoints:
        assert np.all(s.position >= lower - 1e-9) and np.all(s.position <= upper + 1e-9)
        assert np.all(np.abs(s.velocity) <= vmax * (1 + 1e-6)), s
        assert np.all(np.abs(s.acceleration) <= amax * (1 + 1e-6)), s


def test_joint_jog_moves_the_right_joint_the_right_way(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    start = core.tracker.position.copy()
    v = np.zeros(6)
    v[2] = -0.3
    clock.run(0.5, lambda now: core.stream(CommandMode.jog, v, None, 0.1, now))
    moved = core.tracker.position - start
    assert moved[2] < -0.1
    assert np.allclose(np.delete(moved, 2), 0.0)
    assert math.isclose(core.tracker.velocity[2], -0.3, rel_tol=1e-6)


def test_jog_stops_when_commands_stop_arriving(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    v = np.array([0.5, 0, 0, 0, 0, 0])
    clock.run(0.4, lambda now: core.stream(CommandMode.jog, v, None, 0.05, now))
    assert core.tracker.velocity[0] > 0.4
    clock.run(0.5)  # no more commands: the 50 ms timeout lapses, the robot halts
    assert core.command is None
    assert core.command_timeouts == 1
    assert np.allclose(core.tracker.velocity, 0.0)
    stopped_at = core.tracker.position.copy()
    clock.run(0.2)
    assert np.array_equal(core.tracker.position, stopped_at)
    assert_within_limits(core)


def test_freedrive_lets_a_hand_move_the_arm_only_while_held(core: SimCore) -> None:
    clock = Clock(core)
    push = np.array([0, 0, 0, 0.4, 0, 0])
    core.push(push)  # a hand on the arm, not held free: nothing moves
    clock.run(0.2)
    start = core.tracker.position.copy()
    core.set_mode(CommandMode.freedrive)
    clock.run(0.2)
    assert np.array_equal(core.tracker.position, start)  # free only while commands come

    def held(now: float) -> None:
        core.stream(CommandMode.freedrive, np.zeros(6), None, 0.1, now)

    clock.run(0.5, held)
    moved = core.tracker.position - start
    assert moved[3] > 0.1 and np.allclose(np.delete(moved, 3), 0.0)
    clock.run(0.5)  # let go of the button: the 100 ms lapses, the arm holds
    assert core.command is None and np.allclose(core.tracker.velocity, 0.0)
    stopped_at = core.tracker.position.copy()
    clock.run(0.2)
    assert np.array_equal(core.tracker.position, stopped_at)
    assert_within_limits(core)


def test_freedrive_ends_with_the_e_stop_and_a_push_must_be_finite(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.freedrive)
    core.push(np.array([0.4, 0, 0, 0, 0, 0]))
    clock.run(0.2, lambda now: core.stream(CommandMode.freedrive, np.zeros(6), None, 0.1, now))
    core.set_estop(True)
    assert core.mode is CommandMode.halt
    with pytest.raises(RobotError, match="not ready"):
        core.stream(CommandMode.freedrive, np.zeros(6), None, 0.1, clock.now)
    with pytest.raises(InvalidValue, match="finite"):
        core.push(np.array([math.nan, 0, 0, 0, 0, 0]))


def test_only_a_robot_with_freedrive_takes_freedrive(ur5: RobotInfo) -> None:
    panda = load_robot_info("panda")
    robot = SimRobot(DeviceIdentity(uuid="p", kind="robot", model="panda", name="p"), panda)
    robot.core.enable()
    with pytest.raises(RobotError, match="cannot be moved by hand") as refused:
        asyncio.run(robot.set_command_mode(CommandModeRequest(mode=CommandMode.freedrive)))
    assert refused.value.code == "no_freedrive"
    assert "freedrive" in ur5.capabilities


@pytest.mark.parametrize("elbow", [0.3, 0.6, 0.9, 1.2])
def test_a_halt_brakes_along_the_path_and_the_tcp_never_speeds_up(
    ur5: RobotInfo, elbow: float
) -> None:
    """A shoulder and an elbow moving so their motions nearly cancel at the TCP: stopped one
    joint at a time, the TCP would speed up while halting (past the manual-mode cap, seen
    at 0.27 m/s from 0.09); the halt slows every joint in step instead."""
    core = SimCore(ur5, Kinematics(ur5))
    core.tracker = JointTracker(ur5.joints, CYCLE, np.array([0.133, -0.6, elbow, -1.44, -1.57, 0]))
    core.enable()
    clock = Clock(core)
    core.set_mode(CommandMode.velocity_command)
    v = np.array([-0.094, 0.53, -1.161, 0.376, 0.008, -0.024])
    clock.run(0.6, lambda now: core.stream(CommandMode.velocity_command, v, None, 0.2, now))
    core.halt()
    first = len(core.setpoints)
    clock.run(0.6)
    kinematics = Kinematics(ur5)
    speeds = [
        float(np.linalg.norm(kinematics.jacobian(s.position)[:3] @ s.velocity))
        for s in list(core.setpoints)[first - 1 :]
    ]
    assert speeds[0] > 0.05 and speeds[-1] < 1e-9
    assert max(speeds) <= speeds[0] * 1.01
    # It keeps its direction while it matters (the last few mm/s drift as ruckig re-plans).
    start = np.linalg.norm(core.setpoints[first].velocity)
    directions = [
        s.velocity / np.linalg.norm(s.velocity)
        for s in list(core.setpoints)[first:]
        if np.linalg.norm(s.velocity) > 0.25 * start
    ]
    assert min(float(d @ directions[0]) for d in directions) > 0.99
    assert_within_limits(core)


def test_jog_into_a_position_limit_stops_exactly_at_it(ur5: RobotInfo) -> None:
    core = SimCore(ur5, Kinematics(ur5), history=20000)
    core.enable()
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    v = np.zeros(6)
    v[2] = ur5.joints[2].max_velocity  # elbow, limits ±π, starts at π/2
    clock.run(3.0, lambda now: core.stream(CommandMode.jog, v, None, 0.1, now))
    assert core.tracker.position[2] == pytest.approx(ur5.joints[2].upper, abs=1e-6)
    assert not core.error
    assert_within_limits(core)


def test_random_command_storm_never_exceeds_limits(ur5: RobotInfo) -> None:
    rng = np.random.default_rng(7)
    core = SimCore(ur5, Kinematics(ur5), history=100_000)
    core.enable()
    clock = Clock(core)
    vmax = np.array([j.max_velocity for j in ur5.joints])
    for _ in range(40):
        modes = [
            CommandMode.jog,
            CommandMode.velocity_command,
            CommandMode.position_command,
            CommandMode.halt,
        ]
        mode = modes[int(rng.integers(len(modes)))]
        core.set_mode(mode)
        if mode is CommandMode.halt:
            clock.run(0.1)
            continue
        if mode is CommandMode.position_command:
            target = rng.uniform([j.lower for j in ur5.joints], [j.upper for j in ur5.joints])
            clock.run(0.3, lambda now, t=target, m=mode: core.stream(m, None, t, 0.05, now))
        else:
            v = rng.uniform(-vmax, vmax)
            core.set_speed_ratio(float(rng.uniform(0.1, 1.0)))
            clock.run(0.3, lambda now, v=v, m=mode: core.stream(m, v, None, 0.05, now))
    assert not core.error, core.error_message
    assert_within_limits(core)


def test_estop_halts_within_limits_and_blocks_motion(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    v = np.array([0, 2.0, 0, 0, 0, 0])
    clock.run(0.5, lambda now: core.stream(CommandMode.jog, v, None, 0.2, now))
    core.set_estop(True)
    assert not core.enabled and core.mode is CommandMode.halt
    clock.run(1.0)
    assert np.allclose(core.tracker.velocity, 0.0)
    assert_within_limits(core)
    with pytest.raises(RobotError) as err:
        core.set_mode(CommandMode.jog)
    assert err.value.code == "not_enabled"
    with pytest.raises(RobotError):
        core.enable()
    core.set_estop(False)
    core.enable()
    core.set_mode(CommandMode.jog)


def test_fault_stops_motion_until_reset(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    clock.run(0.2, lambda now: core.stream(CommandMode.jog, np.full(6, 0.2), None, 0.2, now))
    core.fault("simulated overload")
    assert core.error and core.error_message == "simulated overload"
    clock.run(0.5)
    assert np.allclose(core.tracker.velocity, 0.0)
    with pytest.raises(RobotError):
        core.stream(CommandMode.jog, np.zeros(6), None, 0.1, clock.now)
    core.reset_errors()
    core.set_mode(CommandMode.jog)


def test_mode_change_passes_through_halt(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    clock.run(0.2, lambda now: core.stream(CommandMode.jog, np.full(6, 0.3), None, 0.5, now))
    core.set_mode(CommandMode.position_command)
    assert core.command is None
    clock.run(0.5)
    assert np.allclose(core.tracker.velocity, 0.0)


def test_trajectory_reaches_its_end(core: SimCore, ur5: RobotInfo) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.trajectory)
    start = core.tracker.position.copy()
    goal = start + np.array([0.4, -0.2, 0.3, 0.1, -0.1, 0.5])
    checker = JointLimitChecker(ur5)
    trajectory = JointTrajectory(
        waypoints=[
            TrajectoryWaypoint(time_from_start=1.0, position=list(start + (goal - start) / 2)),
            TrajectoryWaypoint(time_from_start=2.0, position=list(goal)),
        ]
    )
    trajectory_id = core.start_trajectory(checker.trajectory(trajectory, start))
    clock.run(1.0)
    assert core.trajectory_status(trajectory_id).state is TrajectoryState.running
    clock.run(2.0)
    status = core.trajectory_status(trajectory_id)
    assert status.state is TrajectoryState.finished and status.progress == 1.0
    assert np.allclose(core.tracker.position, goal, atol=1e-9)
    assert_within_limits(core)


def test_position_stream_tracks_a_moving_reference(core: SimCore) -> None:
    clock = Clock(core)
    core.set_mode(CommandMode.position_command)
    start = core.tracker.position.copy()

    def reference(t: float) -> FloatArray:
        result: FloatArray = start + 0.2 * np.sin(2 * np.pi * 0.5 * t)
        return result

    errors = []

    def send(now: float) -> None:
        # The tracker's setpoint is the previous cycle's result: compare it with then.
        errors.append(np.abs(core.tracker.position - reference(now - CYCLE)).max())
        core.stream(CommandMode.position_command, None, reference(now), 0.05, now)

    clock.run(3.0, send)
    # The sine starts with a velocity step the robot must first catch up with; once on it,
    # the setpoint follows within 5 mrad.
    assert max(errors[500:]) < 0.005
    assert_within_limits(core)


def test_driver_rejects_non_finite_and_out_of_limit_targets(ur5: RobotInfo) -> None:
    robot = SimRobot(DeviceIdentity(uuid="u-1", kind="robot", model="ur5", name="t"), ur5)
    with robot.lock:
        robot.core.enable()
        robot.core.set_mode(CommandMode.jog)

    async def scenario() -> None:
        bad = [0.0] * 6
        bad[1] = math.nan
        with pytest.raises(RobotError) as err:
            await robot.jog_joint(JogJointCommand.model_construct(velocity=bad, timeout=0.1))
        assert err.value.code == "not_finite"
        with pytest.raises(RobotError) as err:
            await robot.jog_joint(JogJointCommand(velocity=[9.0, 0, 0, 0, 0, 0], timeout=0.1))
        assert err.value.code == "velocity_limit"
        with pytest.raises(RobotError) as err:
            await robot.jog_joint(JogJointCommand(velocity=[0.0] * 5, timeout=0.1))
        assert err.value.code == "wrong_length"
        await robot.set_command_mode(CommandModeRequest(mode=CommandMode.position_command))
        with pytest.raises(RobotError) as err:
            await robot.position_command(PositionCommand(position=[0, 0, 4.0, 0, 0, 0]))
        assert err.value.code == "position_limit"

    asyncio.run(scenario())
    assert robot.core.command is None  # nothing was accepted
    assert np.allclose(robot.core.tracker.position, ur5.home)


def test_a_position_stream_near_a_limit_brakes_in_time(ur5: RobotInfo) -> None:
    """The elbow arrives fast near its limit and a stream then swings its target across
    the limit: the robot must brake in time on its own, not fault and not overshoot."""
    core = SimCore(ur5, Kinematics(ur5), history=20000)
    core.enable()
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    full = np.array([j.max_velocity for j in ur5.joints])
    clock.run(0.5, lambda now: core.stream(CommandMode.jog, full, None, 0.1, now))
    clock.run(0.2)  # the jog lapses; the robot is still braking
    core.set_mode(CommandMode.position_command)
    here = core.tracker.position.copy()
    assert ur5.joints[2].upper - here[2] < 0.2
    ticks = iter(range(10**6))

    def send(now: float) -> None:
        k = next(ticks)
        if k % 5 == 0:  # a 100 Hz stream
            core.stream(CommandMode.position_command, None, here + 0.3 * np.sin(k / 30), 0.1, now)

    clock.run(1.0, send)
    assert not core.error, core.error_message
    assert core.tracker.guard_trips > 0
    assert_within_limits(core)


def test_tiny_velocities_far_from_the_limits_are_followed(core: SimCore) -> None:
    """A Cartesian jog gives some joints velocities of 1e-6 rad/s; aiming those at a limit
    6 rad away would ask ruckig for a trajectory it cannot time."""
    clock = Clock(core)
    core.set_mode(CommandMode.velocity_command)
    v = np.array([1e-6, -2e-7, 0.3, 1e-8, -1e-5, 0.0])
    clock.run(0.5, lambda now: core.stream(CommandMode.velocity_command, v, None, 0.1, now))
    assert not core.error, core.error_message
    assert np.allclose(core.tracker.velocity, v, atol=1e-12)


def straight_trajectory(
    core: SimCore, ur5: RobotInfo, offset: list[float]
) -> tuple[str, FloatArray, FloatArray]:
    """A time-optimal move along a straight line in joint space, sent as 8 ms waypoints with
    velocities and accelerations, as the motion service sends it; (trajectory id, start,
    goal)."""
    from openpendant.runtime.robotics.joint_move import plan_joint_move

    start = core.tracker.position.copy()
    goal = start + np.array(offset)
    move = plan_joint_move(core.kinematics, ur5, start, goal, 1.0, None)
    times = np.arange(0.008, move.duration, 0.008).tolist() + [move.duration]
    waypoints = []
    for t in times:
        position, velocity, acceleration = move.state(t)
        if t == times[-1]:
            velocity, acceleration = 0 * velocity, 0 * acceleration
        waypoints.append(
            TrajectoryWaypoint(
                time_from_start=t,
                position=list(position),
                velocity=list(velocity),
                acceleration=list(acceleration),
            )
        )
    checked = JointLimitChecker(ur5).trajectory(JointTrajectory(waypoints=waypoints), start)
    core.set_mode(CommandMode.trajectory)
    return core.start_trajectory(checked), start, goal


def off_the_line(q: FloatArray, start: FloatArray, goal: FloatArray) -> float:
    direction = (goal - start) / np.linalg.norm(goal - start)
    along = float((q - start) @ direction)
    return float(np.linalg.norm(q - start - along * direction))


def test_a_pause_stops_on_the_path_and_resume_finishes_it(core: SimCore, ur5: RobotInfo) -> None:
    clock = Clock(core)
    trajectory_id, start, goal = straight_trajectory(core, ur5, [1.2, -0.4, 0.5, 0.3, -0.3, 0.8])
    clock.run(0.6)
    assert np.max(np.abs(core.tracker.velocity)) > 0.3
    core.pause_trajectory(True)
    paused_at = core.sim_time
    clock.run(1.0)
    status = core.trajectory_status(trajectory_id)
    assert status.state is TrajectoryState.paused and status.progress < 0.9
    assert np.allclose(core.tracker.velocity, 0.0)
    stopped = [s for s in core.setpoints if np.max(np.abs(s.velocity)) < 1e-9 and s.t > paused_at]
    assert stopped and stopped[0].t - paused_at < 0.5  # a controlled stop, not a crawl
    held = core.tracker.position.copy()
    clock.run(0.5)
    assert np.abs(core.tracker.position - held).max() < 1e-9  # paused means still
    core.pause_trajectory(False)
    clock.run(6.0)
    assert core.trajectory_status(trajectory_id).state is TrajectoryState.finished
    assert np.allclose(core.tracker.position, goal, atol=1e-9)
    # On the straight line all the way: stopping and starting again never left it.
    worst = max(off_the_line(s.position, start, goal) for s in core.setpoints)
    assert worst < 1e-4, f"{worst:.2e} rad off the path"
    assert_within_limits(core)


def test_the_speed_override_slows_a_running_trajectory_on_its_path(
    core: SimCore, ur5: RobotInfo
) -> None:
    clock = Clock(core)
    trajectory_id, start, goal = straight_trajectory(core, ur5, [1.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    clock.run(0.5)
    full = float(np.max(np.abs(core.tracker.velocity)))
    core.set_speed_ratio(0.25)
    clock.run(0.5)
    slowed = float(np.max(np.abs(core.tracker.velocity)))
    assert slowed < 0.35 * full
    core.set_speed_ratio(1.0)
    clock.run(6.0)
    assert core.trajectory_status(trajectory_id).state is TrajectoryState.finished
    assert np.allclose(core.tracker.position, goal, atol=1e-9)
    worst = max(off_the_line(s.position, start, goal) for s in core.setpoints)
    assert worst < 1e-6
    assert_within_limits(core)


def test_pausing_without_a_trajectory_is_refused(core: SimCore) -> None:
    with pytest.raises(RobotError) as refused:
        core.pause_trajectory(True)
    assert refused.value.code == "not_running"


def test_placing_the_arm_puts_it_there_at_rest_and_only_while_it_stands(core: SimCore) -> None:
    """The simulator's set-up shortcut: refused while the arm moves, outside the limits
    or with a value that is not a number; done, the arm stays put."""
    clock = Clock(core)
    core.set_mode(CommandMode.jog)
    v = np.array([0.5, 0, 0, 0, 0, 0])
    clock.run(0.2, lambda now: core.stream(CommandMode.jog, v, None, 0.05, now))
    target = np.array([0.3, -1.2, 1.1, -1.4, -1.57, 0.2])
    with pytest.raises(RobotError, match="moving"):
        core.place(target)
    clock.run(0.6)  # the jog's commands lapse: it halts
    with pytest.raises(RobotError, match="limits"):
        core.place(np.array([9.0, 0, 0, 0, 0, 0]))
    with pytest.raises(InvalidValue):
        core.place(np.array([math.nan, 0, 0, 0, 0, 0]))
    core.place(target)
    clock.run(0.2)
    assert np.allclose(core.tracker.position, target, atol=1e-12)
    assert np.allclose(core.tracker.velocity, 0.0)


def test_a_faster_clock_runs_trajectories_only_and_on_the_same_path(ur5: RobotInfo) -> None:
    """Issue 33: the test suite's time scale. A robot at 5x plays its trajectory in a fifth
    of the loop's periods, through the same setpoints a robot at 1x passes; a stream (a jog)
    stays in real time, its commands' deadlines with it."""
    identity = DeviceIdentity(uuid="u-1", kind="robot", model="ur5", name="t")
    paths = {}
    for scale in (1, 5):
        robot = SimRobot(identity, ur5, time_scale=scale)
        robot.core.enable()
        trajectory_id, _, goal = straight_trajectory(robot.core, ur5, [0.8, -0.3, 0.4, 0, 0, 0])
        periods = 0
        while robot.core.trajectory_status(trajectory_id).state != "finished":
            robot.cycle(periods * CYCLE)
            periods += 1
            assert periods < 10_000
        paths[scale] = (periods, np.array([s.position for s in robot.core.setpoints]))
        assert np.allclose(robot.core.tracker.position, goal, atol=1e-6)
    (slow, slow_path), (fast, fast_path) = paths[1], paths[5]
    assert abs(fast * 5 - slow) <= 5
    assert np.abs(fast_path[: len(slow_path)] - slow_path[: len(fast_path)]).max() < 1e-12

    robot = SimRobot(identity, ur5, time_scale=5)
    robot.core.enable()
    robot.core.set_mode(CommandMode.jog)
    robot.core.stream(CommandMode.jog, np.array([0.3, 0, 0, 0, 0, 0]), None, 0.1, 0.0)
    for k in range(10):
        robot.cycle(k * CYCLE)
    assert robot.core.sim_time == pytest.approx(10 * CYCLE)


def planned_move_samples(ur5: RobotInfo, core: SimCore) -> tuple[Any, FloatArray, FloatArray]:
    """A Move to's planned joint move, and its line's start and goal."""
    start = core.tracker.position.copy()
    goal = start + np.array([0.6, -0.3, 0.4, 0.2, -0.2, 0.5])
    return plan_joint_move(Kinematics(ur5), ur5, start, goal, 1.0, None), start, goal


def test_a_stream_held_up_and_delivered_at_once_never_carries_the_arm_past_its_goal(
    ur5: RobotInfo,
) -> None:
    """A Move to's samples (every 10 ms) held up on their way for 30-60 ms near the move's
    end, then delivered together. The driver took their spacing (0.2 ms) for the stream's,
    extrapolated the acceleration that gave, and the arm went up to 0.34 rad past the goal,
    off the path that was checked (a loaded machine: the path monitor halted it 6.4 mm off)."""
    period, gap = 0.01, 0.0002
    for stall_at in (0.55, 0.65, 0.7, 0.75):
        for stall in (0.03, 0.06):
            core = SimCore(ur5, Kinematics(ur5))
            core.enable()
            core.set_mode(CommandMode.position_command)
            move, start, goal = planned_move_samples(ur5, core)
            sent = np.arange(0.0, move.duration + 0.3, period)
            arrivals: list[tuple[float, float]] = []  # (received, sent)
            held: list[float] = []
            for t in sent:
                if stall_at <= t < stall_at + stall:
                    held.append(t)
                    continue
                arrivals += [(t + k * gap, h) for k, h in enumerate([*held, t])]
                held = []
            length = float(np.linalg.norm(goal - start))
            direction = (goal - start) / length
            now, beyond = 0.0, 0.0
            while now < sent[-1] + 0.3:
                now += CYCLE
                while arrivals and arrivals[0][0] <= now:
                    received, t = arrivals.pop(0)
                    p, v = move.sample(min(t, move.duration))
                    if t >= move.duration:
                        p, v = move.goal, np.zeros_like(move.goal)
                    core.stream(CommandMode.position_command, v, p, 0.2, received)
                core.step(now)
                q = core.tracker.position
                beyond = max(beyond, float((q - start) @ direction) - length)
                assert off_the_line(q, start, goal) < 1e-9
            # As on time (the tracker's own last 6e-5 rad of catching up with the goal).
            assert beyond < 2e-4, (stall_at, stall, beyond)
    assert_within_limits(core)


def test_a_stream_that_stops_arriving_brakes_the_arm_within_two_of_its_periods(
    ur5: RobotInfo, core: SimCore
) -> None:
    """Not carried on, still speeding up as its last samples did, until the stream's timeout
    (200 ms here: the arm went from 2.4 to 3.2 rad/s along its line, 1 rad further)."""
    period = 0.01
    core.set_mode(CommandMode.position_command)
    move, _, _ = planned_move_samples(ur5, core)
    now, last, speeds = 0.0, 0.0, []
    while now < 0.9:
        now += CYCLE
        if now < 0.4 and now - last >= period - 1e-9:
            p, v = move.sample(now)
            core.stream(CommandMode.position_command, v, p, 0.2, now)
            last = now
        core.step(now)
        speeds.append((now, float(np.linalg.norm(core.tracker.velocity))))
    at_last = next(s for t, s in speeds if t >= last - 1e-9)
    after = [s for t, s in speeds if t > last]
    # The jerk limit lets the acceleration die away over a few cycles, no more.
    assert max(after) < at_last * 1.05, (max(after), at_last)
    braking = [s for t, s in speeds if t > last + 2 * period + 4 * CYCLE]
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(braking))
    assert braking[-1] == 0.0


def test_a_trajectory_stopped_while_it_was_prepared_never_starts(
    ur5: RobotInfo, monkeypatch: pytest.MonkeyPatch
) -> None:
    """STOP, then the trajectory mode set again, while the driver prepared a trajectory off
    its lock: that trajectory is refused, not started after the STOP."""
    robot = SimRobot(DeviceIdentity(uuid="u-1", kind="robot", model="ur5", name="t"), ur5)
    with robot.lock:
        robot.core.enable()
        robot.core.set_mode(CommandMode.trajectory)
    preparing = threading.Event()
    release = threading.Event()
    prepare = robot.core.prepare

    def held_prepare(trajectory: Any) -> Any:
        preparing.set()
        release.wait(5)
        return prepare(trajectory)

    monkeypatch.setattr(robot.core, "prepare", held_prepare)
    goal = [v + 0.3 for v in ur5.home]
    move = JointTrajectory(waypoints=[TrajectoryWaypoint(time_from_start=2.0, position=goal)])

    async def scenario() -> None:
        started = asyncio.create_task(robot.execute_trajectory(move))
        await asyncio.to_thread(preparing.wait, 5)
        await robot.halt()
        await robot.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory))
        release.set()
        with pytest.raises(RobotError) as refused:
            await started
        assert refused.value.code == "interrupted"

    asyncio.run(scenario())
    assert robot.core.trajectory is None  # nothing runs
