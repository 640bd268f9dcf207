"""The robot's speed override bounds every jog, whatever the client asks (issue 32: the jog
service took the speed the page sent, so a page or a script asking 100 % jogged at 100 %
with the robot's override at 10 %, and the manual mode's 250 mm/s cap was not scaled: a
newcomer's first one-second hold at 10 % moved the UR5's TCP 31 mm, a UR10's more).

Each press is run cycle by cycle against a robot that follows its commands exactly, on every
robot model: at a 10 % override a one-second hold moves the TCP at most 25 mm (10 % of the
cap), and an override lowered while a press is held slows it within the ramp, a Move to
too."""

from __future__ import annotations

import numpy as np
import pytest

from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    OperationalMode,
    RobotFlags,
    RobotState,
)
from openpendant.runtime.jog.actions import (
    LATE_TICK,
    RATE_CHANGE,
    JointVelocityJog,
    PlannedMoveAction,
    TwistJog,
)
from openpendant.runtime.jog.session import JOINT_SPEED, LINEAR_SPEED
from openpendant.runtime.robotics.joint_move import plan_joint_move
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import available_models, load_robot_info
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED, VelocityController

MODELS = available_models()
PERIOD = 0.01


def state(kinematics: Kinematics, q: FloatArray, ratio: float) -> RobotState:
    return RobotState(
        seqno=0,
        ts=0.0,
        command_mode=CommandMode.velocity_command,
        operational_mode=OperationalMode.manual_reduced_speed,
        flags=RobotFlags(enabled=True, ready=True, homed=True),
        joint_position=q.tolist(),
        joint_velocity=[0.0] * q.size,
        joint_position_command=q.tolist(),
        tcp_pose=kinematics.tcp_pose(q),
        speed_ratio=ratio,
    )


def hold(
    kinematics: Kinematics, action: JointVelocityJog | TwistJog, q: FloatArray, ratios: list[float]
) -> tuple[FloatArray, list[float]]:
    """Run the press for len(ratios) cycles, the override at each; the joints follow the
    commands. Returns the joints at the end and the TCP speed of each cycle."""
    speeds = []
    for k, ratio in enumerate(ratios):
        command = action.tick(state(kinematics, q, ratio), k * PERIOD)
        velocity = np.array(command.velocity)
        speeds.append(float(np.linalg.norm(kinematics.jacobian(q)[:3] @ velocity)))
        q = q + velocity * PERIOD
    return q, speeds


def parts(model: str) -> tuple[Kinematics, VelocityController, FloatArray]:
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    controller = VelocityController(
        kinematics,
        np.array([j.max_velocity for j in info.joints]),
        np.array([j.max_acceleration for j in info.joints]),
        PERIOD,
    )
    return kinematics, controller, np.array(info.home, dtype=float)


@pytest.mark.parametrize("model", MODELS)
def test_a_first_hold_of_the_base_joint_asking_full_speed_runs_at_the_override(model: str) -> None:
    kinematics, controller, home = parts(model)
    velocity = np.zeros(home.size)
    velocity[0] = JOINT_SPEED
    action = JointVelocityJog("p", controller, velocity, MANUAL_TCP_SPEED, speed=1.0)
    second = round(1.0 / PERIOD)
    q, speeds = hold(kinematics, action, home, [0.1] * second)
    moved = float(np.linalg.norm(kinematics.tcp(q).translation - kinematics.tcp(home).translation))
    assert max(speeds) <= 0.1 * MANUAL_TCP_SPEED + 1e-9
    assert 0.005 < moved <= 0.1 * MANUAL_TCP_SPEED * 1.0 + 1e-9, f"{moved * 1000:.1f} mm"
    assert abs(q[0] - home[0]) <= 0.1 * JOINT_SPEED + 1e-9


@pytest.mark.parametrize("model", MODELS)
def test_a_cartesian_hold_asking_full_speed_runs_at_the_override(model: str) -> None:
    kinematics, controller, home = parts(model)
    twist = np.array([LINEAR_SPEED, 0, 0, 0, 0, 0], dtype=float)
    action = TwistJog("p", controller, kinematics, twist, "base", MANUAL_TCP_SPEED, speed=1.0)
    _, speeds = hold(kinematics, action, home, [0.1] * 100)
    assert max(speeds) <= 0.1 * MANUAL_TCP_SPEED + 1e-9


def test_an_override_lowered_during_a_hold_slows_it() -> None:
    kinematics, controller, home = parts("ur5")
    velocity = np.zeros(home.size)
    velocity[0] = JOINT_SPEED
    action = JointVelocityJog("p", controller, velocity, MANUAL_TCP_SPEED, speed=1.0)
    _, speeds = hold(kinematics, action, home, [1.0] * 50 + [0.1] * 50)
    assert speeds[49] > 0.2  # at the 250 mm/s cap, near enough
    assert max(speeds[80:]) <= 0.1 * MANUAL_TCP_SPEED + 1e-9


def test_a_client_asking_less_than_the_override_gets_what_it_asked() -> None:
    kinematics, controller, home = parts("ur5")
    twist = np.array([LINEAR_SPEED, 0, 0, 0, 0, 0], dtype=float)
    action = TwistJog("p", controller, kinematics, twist, "base", MANUAL_TCP_SPEED, speed=0.05)
    _, speeds = hold(kinematics, action, home, [1.0] * 100)
    assert speeds[-1] == pytest.approx(0.05 * min(LINEAR_SPEED, MANUAL_TCP_SPEED), rel=0.05)


@pytest.mark.parametrize("reported", [float("nan"), -1.0, 2.0, float("inf")])
def test_an_override_out_of_range_moves_nothing(reported: float) -> None:
    kinematics, controller, home = parts("ur5")
    velocity = np.zeros(home.size)
    velocity[0] = JOINT_SPEED
    action = JointVelocityJog("p", controller, velocity, MANUAL_TCP_SPEED, speed=1.0)
    _, speeds = hold(kinematics, action, home, [reported] * 50)
    assert max(speeds) == 0.0


@pytest.mark.parametrize("model", MODELS)
def test_an_override_lowered_during_a_held_move_to_slows_it_on_its_path(model: str) -> None:
    """A Move to (or a step) planned at 100 % slows to the override lowered while it runs,
    along the positions that were planned and checked, and never runs faster than planned
    when the override is raised above it again."""
    info = load_robot_info(model)
    kinematics = Kinematics(info)
    home = np.array(info.home, dtype=float)
    goal = home + 0.6
    move = plan_joint_move(kinematics, info, home, goal, 1.0, MANUAL_TCP_SPEED)
    action = PlannedMoveAction("p", move, speed=1.0)
    positions, speeds, t = [], [], 0.0
    q = home.copy()
    for k in range(100_000):
        ratio = 1.0 if t < 0.2 * move.duration else 0.1
        command = action.tick(state(kinematics, q, ratio), t)
        q = np.array(command.position)
        positions.append(q)
        speeds.append(float(np.max(np.abs(np.array(command.velocity or [])))))
        t = (k + 1) * PERIOD
        if action.progress >= move.duration:
            break
    fast = float(np.max(np.abs(move.sample(0.5 * move.duration)[1])))
    slowed = round(0.2 * move.duration / PERIOD) + round(1.0 / RATE_CHANGE / PERIOD) + 1
    assert max(speeds[slowed:]) <= 0.1 * fast + 1e-6
    assert t > 3 * move.duration  # the rest at a tenth of its speed
    # Every position commanded is one the plan passes through (the path checked).
    on_plan = np.array([move.sample(float(s))[0] for s in np.linspace(0, move.duration, 20_000)])
    for position in positions[:: max(1, len(positions) // 200)]:
        assert np.min(np.max(np.abs(on_plan - position), axis=1)) < 1e-3
    assert np.allclose(positions[-1], goal)
    # Raised above the speed it was planned at, it runs no faster than planned.
    again = PlannedMoveAction("p", move, speed=0.5)
    for k in range(300):
        command = again.tick(state(kinematics, home, 1.0), k * PERIOD)
        velocity = np.array(command.velocity or [])
        assert np.all(np.abs(velocity) <= np.abs(move.sample(k * PERIOD)[1]) + 1e-9)


def test_a_late_tick_does_not_leap_a_move_to_ahead() -> None:
    """The jog service held up for 150 ms (a loaded machine): the next sample of the Move to
    is at most LATE_TICK further along its plan, not 150 ms further (0.35 rad of a UR5's
    fast move sent to the robot at once)."""
    info = load_robot_info("ur5")
    kinematics = Kinematics(info)
    home = np.array(info.home, dtype=float)
    move = plan_joint_move(kinematics, info, home, home + 0.6, 1.0, None)
    action = PlannedMoveAction("p", move, speed=1.0)
    t = 0.0
    for _ in range(30):
        action.tick(state(kinematics, home, 1.0), t)
        t += PERIOD
    before = action.progress
    action.tick(state(kinematics, home, 1.0), t + 0.15)
    assert action.progress - before == pytest.approx(LATE_TICK)
    assert LATE_TICK < 0.15
