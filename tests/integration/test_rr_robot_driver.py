"""The rr-robot driver (plugins/robotraconteur) against an RR standard robot written on
`robotraconteur-abstract-robot` (tests/support/rr_sim_arm.py), over rr+tcp on loopback with
RR's discovery off (so nothing is sent beyond this machine's loopback): its info read from
the robot, its state, a jog that stops when its commands stop, a trajectory streamed on its
planned path, a halt, the E-stop a fault until reset, and the robot gone a fault from which
nothing resumes."""

from __future__ import annotations

import asyncio
import signal
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from openpendant.plugins.robotraconteur.entry import RRRobotOptions, create
from openpendant.plugins.robotraconteur.robot_driver import RRRobotDriver
from openpendant.runtime.bench.harness.processes import wait_for
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    JogJointCommand,
    JointTrajectory,
    PositionCommand,
    SpeedRatioRequest,
    TrajectoryState,
    TrajectoryWaypoint,
)
from openpendant.runtime.kit.errors import RobotError
from openpendant.runtime.robotics.kinematics import Kinematics
from tests.support.rr_service import RRService


class Arm(RRService):
    """The simulated RR arm's process."""

    def __init__(self) -> None:
        super().__init__("rr_sim_arm", "robot")

    def estop(self, pressed: bool) -> None:
        self.proc.send_signal(signal.SIGUSR1 if pressed else signal.SIGUSR2)

    def set(self, name: str, value: Any, kind: str = "") -> None:
        """One of the arm's test parameters (rr_sim_arm.py)."""
        super().set(name, value, kind or ("string" if isinstance(value, str) else "int32"))

    def modes_set(self) -> list[int]:
        """The command modes clients set on the arm, in order (RR's numbers)."""
        return [int(m) for m in self.get("modes_set")]


class Driven:
    """The driver made as its host makes it, on its own loop in this thread."""

    def __init__(self, arm: Arm) -> None:
        self.loop = asyncio.new_event_loop()
        driver = create("arm", "rr-arm-1", RRRobotOptions(url=arm.url))
        assert isinstance(driver, RRRobotDriver)
        self.driver = driver
        self.run(driver.start())

    def run(self, work: Any) -> Any:
        return self.loop.run_until_complete(work)

    def q(self) -> np.ndarray:
        return np.array(self.driver.state().joint_position)

    def ready(self) -> None:
        self.run(self.driver.enable())
        wait_for(lambda: self.driver.state().flags.ready, 10, what="ready")

    def close(self) -> None:
        self.run(self.driver.shutdown())
        self.loop.close()


def halted_in_rr(driver: RRRobotDriver) -> bool:
    link, reading = driver.link, driver.reading
    return link is not None and reading is not None and reading.command_mode == link.modes["halt"]


def halted_at_rest(driver: RRRobotDriver) -> bool:
    return halted_in_rr(driver) and bool(np.abs(driver.state().joint_velocity).max() < 1e-9)


@pytest.fixture
def arm() -> Iterator[Arm]:
    arm = Arm()
    yield arm
    arm.stop()


@pytest.fixture
def driven(arm: Arm) -> Iterator[Driven]:
    driven = Driven(arm)
    yield driven
    driven.close()


def test_its_info_and_state_are_read_from_the_robot(driven: Driven) -> None:
    d = driven.driver
    assert d.info.model == "SimArm_UR5" and d.info.manufacturer == "OpenPendant"
    assert d.info.joint_names[0] == "shoulder_pan_joint" and d.info.flange_link == "tool0"
    assert d.info.joints[2].lower == pytest.approx(-np.pi)
    state = d.state()
    assert state.joint_position == pytest.approx([0.0, -1.2, 1.4, -1.8, -1.57, 0.0], abs=1e-9)
    assert not state.flags.error and not state.flags.communication_failure
    # The TCP from the URDF made of the robot's chain: a UR5's at this pose (RR's own
    # kinematics give the same, tests/unit/test_chain_urdf.py).
    assert np.allclose(state.tcp_pose.position, [-0.63545, -0.10922, 0.32785], atol=1e-4)
    seqno = state.seqno
    wait_for(lambda: d.state().seqno > seqno + 10, 2, what="states at the robot's rate")


def test_a_jog_moves_while_commanded_and_stops_when_its_commands_stop(driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    start = driven.q()
    for _ in range(10):
        driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=0.2)))
        time.sleep(0.05)
    wait_for(lambda: driven.q()[0] - start[0] > 0.05, 3, what="jogging")
    wait_for(
        lambda: abs(d.state().joint_velocity[0]) < 1e-9, 2, what="stopped after the last command"
    )
    stopped = driven.q()
    time.sleep(0.3)
    assert np.abs(driven.q() - stopped).max() < 1e-9  # nothing more
    # Still in RR's jog mode, stopped by a jog of its own (not a change of modes per cycle).
    assert d.link is not None and d.reading is not None
    assert d.reading.command_mode == d.link.modes["jog"]
    assert stopped[0] - start[0] < 0.3 * (10 * 0.05 + 0.2) + 0.02
    assert np.abs(stopped[1:] - start[1:]).max() < 1e-9


def test_a_held_jog_follows_the_speed_override_at_once(driven: Driven) -> None:
    """One jog command, held for its 1 s: the override changed meanwhile reaches the robot
    without waiting for the next command."""
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=1.0)))
    wait_for(lambda: abs(d.state().joint_velocity[0] - 0.3) < 0.01, 0.4, what="jogging at 0.3")
    driven.run(d.set_speed_ratio(SpeedRatioRequest(ratio=0.25)))
    wait_for(
        lambda: abs(d.state().joint_velocity[0] - 0.075) < 0.005, 0.3, what="slowed to a quarter"
    )
    driven.run(d.halt())
    wait_for(lambda: halted_at_rest(d), 2, what="halted")


def test_an_estop_named_by_its_source_and_a_fatal_error_are_faults_until_cleared(
    arm: Arm, driven: Driven
) -> None:
    """A robot whose states name only the E-stop's source (a guard), then one that reports a
    fatal error: each a fault while jogging, reset refused while it lasts, nothing resumes."""
    d = driven.driver
    assert d.link is not None
    for flag, said in (("estop_guard1", "E-stop"), ("fatal_error", "fatal error")):
        driven.ready()
        driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
        driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=1.0)))
        arm.set("flags", d.link.flag_bits[flag])
        wait_for(lambda: d.state().flags.error, 3, what=f"{flag}: the fault")
        state = d.state()
        assert said in state.error_message and not state.flags.ready, state
        assert state.flags.estop is (flag == "estop_guard1")
        with pytest.raises(RobotError, match=said):
            driven.run(d.reset_errors())
        arm.set("flags", 0)
        wait_for(lambda: not d.state().flags.estop, 3, what=f"{flag}: cleared")
        held = driven.q()
        time.sleep(0.3)
        assert np.abs(driven.q() - held).max() < 1e-9 and d.state().flags.error
        driven.run(d.reset_errors())


def test_a_trajectory_runs_on_its_planned_path_and_a_halt_stops_the_next(driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory)))
    start = driven.q()
    offsets = np.array([0.4, -0.3, 0.3, 0.2, 0.3, -0.4])
    times = np.linspace(0.2, 2.0, 10)
    waypoints = [
        TrajectoryWaypoint(time_from_start=float(t), position=(start + offsets * t / 2.0).tolist())
        for t in times
    ]
    accepted = driven.run(d.execute_trajectory(JointTrajectory(waypoints=waypoints)))
    seen: list[np.ndarray] = []
    deadline = time.monotonic() + 10
    while driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.running:
        seen.append(driven.q())
        assert time.monotonic() < deadline
        time.sleep(0.005)
    assert driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.finished
    assert np.abs(driven.q() - (start + offsets)).max() < 1e-3
    # Every position the robot reported lies within 1 mm (at the TCP) of the plan.
    kinematics = Kinematics(d.info)
    planned = np.array(
        [kinematics.tcp_pose(start + offsets * s).position for s in np.linspace(0, 1, 2001)]
    )
    gaps = [
        np.linalg.norm(planned - np.array(kinematics.tcp_pose(q).position), axis=1).min()
        for q in seen
    ]
    assert len(seen) > 50 and max(gaps) < 1e-3, max(gaps)

    back = [TrajectoryWaypoint(time_from_start=2.0, position=start.tolist())]
    accepted = driven.run(d.execute_trajectory(JointTrajectory(waypoints=back)))
    wait_for(lambda: abs(d.state().joint_velocity[0]) > 0.05, 5, what="moving back")
    driven.run(d.halt())
    assert driven.run(d.trajectory_status(accepted.id)).state is TrajectoryState.aborted
    # The robot in RR's halt mode, at rest (its last setpoint, on the path, is valid for
    # ten more of its states: it may still reach it).
    wait_for(
        lambda: halted_in_rr(d) and np.abs(d.state().joint_velocity).max() < 1e-9, 2, what="halt"
    )
    halted = driven.q()
    time.sleep(0.3)
    assert np.abs(driven.q() - halted).max() < 1e-9
    assert np.abs(halted - start).max() > 0.1  # it stopped well short of the way back


def test_from_a_trajectory_to_position_commands_the_robot_passes_through_halt(
    arm: Arm, driven: Driven
) -> None:
    """Both are RR's position_command mode: one does not go on as the other."""
    driven.ready()
    d = driven.driver
    assert d.link is not None
    position, halt = d.link.modes["position_command"], d.link.modes["halt"]
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory)))
    wait_for(lambda: arm.modes_set()[-1:] == [position], 3, what="in RR's position mode")
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.position_command)))
    driven.run(d.position_command(PositionCommand(position=driven.q().tolist())))
    wait_for(lambda: arm.modes_set()[-3:] == [position, halt, position], 3, what="through halt")
    assert not d.state().flags.error, d.state().error_message


def test_the_estop_is_a_fault_until_released_and_reset(arm: Arm, driven: Driven) -> None:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))
    driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=1.0)))
    arm.estop(True)
    wait_for(lambda: d.state().flags.estop, 5, what="the E-stop seen")
    state = d.state()
    assert state.flags.error and not state.flags.ready and "E-stop" in state.error_message
    with pytest.raises(RobotError, match="E-stop"):
        driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=1.0)))
    with pytest.raises(RobotError, match="E-stop"):
        driven.run(d.reset_errors())
    arm.estop(False)
    wait_for(lambda: not d.state().flags.estop, 5, what="the E-stop released")
    assert d.state().flags.error  # until reset: nothing resumes by itself
    held = driven.q()
    time.sleep(0.3)
    assert np.abs(driven.q() - held).max() < 1e-9
    driven.run(d.reset_errors())
    driven.ready()
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.jog)))

    def jogged_again() -> bool:  # held: a command every 50 ms
        driven.run(d.jog_joint(JogJointCommand(velocity=[0.3, 0, 0, 0, 0, 0], timeout=0.2)))
        time.sleep(0.05)
        return bool(driven.q()[0] - held[0] > 0.01)

    wait_for(jogged_again, 3, what="jogging again")


def moving_on_a_long_move(driven: Driven) -> tuple[str, np.ndarray]:
    driven.ready()
    d = driven.driver
    driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory)))
    start = driven.q()
    goal = start + np.array([1.0, 0, 0, 0, 0, 0])
    move = [TrajectoryWaypoint(time_from_start=3.0, position=goal.tolist())]
    accepted = driven.run(d.execute_trajectory(JointTrajectory(waypoints=move)))
    wait_for(lambda: driven.q()[0] - start[0] > 0.05, 5, what="moving")
    return accepted.id, start


def test_the_robot_gone_mid_move_is_a_fault_and_nothing_resumes(arm: Arm, driven: Driven) -> None:
    d = driven.driver
    move, _ = moving_on_a_long_move(driven)
    arm.kill()
    wait_for(lambda: d.state().flags.communication_failure, 3, what="the loss seen")
    state = d.state()
    assert state.flags.error and "connection" in state.error_message
    assert driven.run(d.trajectory_status(move)).state is TrajectoryState.failed
    with pytest.raises(RobotError):
        driven.run(d.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory)))


def test_the_robot_no_longer_ready_is_a_fault_and_nothing_resumes(arm: Arm, driven: Driven) -> None:
    """Its drives lose power while it stays enabled: the move fails, and when they are back
    nothing moves until errors are reset and it is enabled again."""
    d = driven.driver
    move, _ = moving_on_a_long_move(driven)
    arm.set("drives", 0)
    wait_for(lambda: d.state().flags.error, 3, what="the fault")
    assert "no longer ready" in d.state().error_message
    assert driven.run(d.trajectory_status(move)).state is TrajectoryState.failed
    arm.set("drives", 1)
    held = driven.q()
    time.sleep(0.5)
    assert np.abs(driven.q() - held).max() < 1e-9
    assert d.state().flags.error and not d.state().flags.ready


def test_an_operational_mode_change_halts_a_move(arm: Arm, driven: Driven) -> None:
    """The key switch turned mid-move (a cobot's mode to automatic): halted, as the UR
    driver halts; the new mode shown; nothing resumes."""
    d = driven.driver
    move, _ = moving_on_a_long_move(driven)
    arm.set("operational_mode", "auto")
    wait_for(lambda: d.state().operational_mode.value == "auto", 3, what="the new mode")
    assert driven.run(d.trajectory_status(move)).state is TrajectoryState.aborted
    wait_for(
        lambda: halted_in_rr(d) and np.abs(d.state().joint_velocity).max() < 1e-9, 2, what="halt"
    )
    held = driven.q()
    time.sleep(0.5)
    assert np.abs(driven.q() - held).max() < 1e-9
    assert d.state().command_mode is CommandMode.halt
