"""servoJ on the emulated UR controller (issue 31), stepped here cycle by cycle: a stream of
targets sampled from a planned linear move, as the UR driver sends them and arriving a few
milliseconds late now and then, keeps the arm's TCP on the line; a target the arm cannot
reach is a protective stop."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from openpendant.device_drivers.ur_rtde.emulator.controller import (
    CYCLE,
    NORMAL,
    PROTECTIVE_STOP,
    SERVOJ,
    STOPPED,
    Controller,
)
from openpendant.runtime.bench.bench_path_fidelity import linear
from openpendant.runtime.interfaces.limits import FloatArray, JointLimitChecker
from openpendant.runtime.motion.executor import trajectory as as_trajectory
from openpendant.runtime.motion.moves import MovePlanner, Point
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.reference import Limits, RunningTrajectory, TrajectoryReference
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.time_scaling import TimeScaling
from openpendant.runtime.robotics.world import World

UR5E = load_robot_info("ur5e")
PERIOD = 0.008  # the driver's servoJ t


def running() -> Controller:
    """The emulated controller with ur-rtde's control script running on it."""
    controller = Controller(UR5E)
    controller.script_received("def rtde_control():\n    # int register offset\n0\n")
    assert controller.runtime_state != STOPPED
    return controller


def servoj(controller: Controller, q: FloatArray) -> None:
    """One servoJ(q, 0, 0, t, 0.1, 300) package, as ur-rtde lays it out."""
    fields: dict[str, object] = {"input_int_register_0": SERVOJ}
    for k, value in enumerate([*q, 0.0, 0.0, PERIOD, 0.1, 300.0]):
        fields[f"input_double_register_{k}"] = float(value)
    controller.apply_inputs(fields)


def fast_line() -> tuple[MovePlanner, list[FloatArray], FloatArray]:
    """The planner, a 600 mm line from home at full speed (automatic mode), and the targets
    the driver streams for it: its start, then one every 8 ms of its clock, then its end
    until the arm is there."""
    world = World()
    world.add_robot("r", UR5E)
    planner = MovePlanner(world, "r", None)  # automatic mode: no TCP cap
    home = np.array(UR5E.home)
    here = planner.kinematics.tcp(home)
    goal = pin.SE3(here.rotation, here.translation + np.array([0.0, 0.6, 0.0]))
    plan = planner.plan(linear(goal), home, [Point(None, goal)])
    assert plan.timed is not None, plan.report.message
    checked = JointLimitChecker(UR5E).trajectory(as_trajectory(plan.timed), home)
    limits = Limits.of(UR5E.joints)
    reference = TrajectoryReference.of(checked).within(limits)
    clock = RunningTrajectory("t", reference)
    scaling = TimeScaling(limits.acceleration, limits.jerk)
    targets = [reference.sample(0.0)[0]]
    while not clock.at_end:
        targets.append(clock.advance(scaling, 1.0, PERIOD)[0])
    targets += [reference.end] * 150
    line = np.array([here.translation, planner.kinematics.tcp(reference.end).translation])
    return planner, targets, line


def mm_off_the_line(arrivals: FloatArray) -> float:
    """The fast line streamed with target k arriving at arrivals[k]: how far the arm's TCP
    left it (mm), once the arm is at the line's end."""
    planner, targets, line = fast_line()
    assert len(arrivals) == len(targets)
    controller = running()
    tcp, sent = [], 0
    for cycle in range(int(arrivals[-1] / CYCLE) + 200):
        while sent < len(targets) and arrivals[sent] <= cycle * CYCLE:
            servoj(controller, targets[sent])
            sent += 1
        controller.step()
        tcp.append(planner.kinematics.tcp(controller.tracker.position).translation)
    assert controller.safety_mode == NORMAL
    assert np.abs(controller.tracker.position - targets[-1]).max() < 1e-9  # it got there
    return float(np.max(distances_to_polyline(line, np.array(tcp)))) * 1000


def on_time(count: int) -> FloatArray:
    return np.arange(count, dtype=float) * PERIOD


def test_a_fast_linear_move_streamed_with_late_packages_stays_on_its_line() -> None:
    """Each target sent on time or up to 4 ms late (never overtaking the one before): late
    ones arrive in the same 2 ms cycle as the next."""
    count = len(fast_line()[1])
    lateness = np.random.default_rng(7).choice([0.0, 0.0, 0.0, 0.001, 0.0025, 0.004], count)
    arrivals = np.maximum.accumulate(on_time(count) + lateness)
    assert mm_off_the_line(arrivals) < 0.1  # it was 10.5 mm


def test_a_client_that_falls_behind_slows_the_move_along_its_line() -> None:
    """The driver's thread held up four times, 40 to 120 ms, and going on from there (as
    its loop does: it never sends the missed targets in a burst): the stream is played
    slower, on its path. Re-timing each late target instead left the line by 3.7-50 mm."""
    arrivals = on_time(len(fast_line()[1]))
    for at, lost in ((30, 0.04), (60, 0.06), (110, 0.12), (160, 0.08)):
        arrivals[at:] += lost
    assert mm_off_the_line(arrivals) < 0.1


def test_targets_that_come_ahead_of_the_controllers_clock_keep_the_move_on_its_line() -> None:
    """The emulator's own loop held up three times, 40 to 80 ms, and going on from there
    (its clock lost that time; the driver's did not): the targets come in bursts, and the
    stream runs ahead of the controller by as much. Re-timed to the controller's clock,
    such a stream asked the arm for 70-120 rad/s² and left the line."""
    arrivals = on_time(len(fast_line()[1]))
    for at, lost in ((20, 0.04), (70, 0.08), (130, 0.06)):
        arrivals[at:] = np.maximum(arrivals[at:] - lost, arrivals[at - 1])
    assert mm_off_the_line(arrivals) < 0.1


def test_a_target_out_of_reach_is_a_protective_stop() -> None:
    """0.5 rad away in one 8 ms period (its lookahead included, the shoulder could go about
    0.34 rad): not a stream but a jump. The arm stays where it was and the program stops."""
    controller = running()
    start = controller.tracker.position.copy()
    servoj(controller, start + np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0]))
    for _ in range(50):
        controller.step()
    assert controller.safety_mode == PROTECTIVE_STOP
    assert controller.runtime_state == STOPPED
    assert np.abs(controller.tracker.position - start).max() < 1e-9
