"""A 3D mouse that goes away while it is switched on (issue 32: its switch went off by itself
when the mouse's driver restarted). Its binding now waits for it, and stays safe: the robot is
halted once when the mouse goes, nothing moves while it is away, and a mouse that comes back
with its cap pushed (a hand on it, or stuck) drives nothing until it has been let go; only a
new deflection from rest moves the robot again.

The binding is run cycle by cycle against a robot that follows its commands exactly, its
mouse's reports set by hand (as the jog service reads them off the mouse's link)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from openpendant.runtime.clients.input import InputClient
from openpendant.runtime.clients.robot import Halt, Streamed
from openpendant.runtime.interfaces.input import InputState
from openpendant.runtime.interfaces.limits import FloatArray
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    OperationalMode,
    RobotFlags,
    RobotState,
    VelocityCommand,
)
from openpendant.runtime.jog.actions import MouseJog
from openpendant.runtime.jog.session import ANGULAR_SPEED, LINEAR_SPEED
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED, VelocityController

PERIOD = 0.01
PUSHED = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0]  # half way to the right
AT_REST = [0.0] * 6


@dataclass
class Feed:
    """The mouse's newest state as the jog service sees it: None while its link is down."""

    state: InputState | None


class Cell:
    def __init__(self) -> None:
        info = load_robot_info("ur5")
        self.kinematics = Kinematics(info)
        controller = VelocityController(
            self.kinematics,
            np.array([j.max_velocity for j in info.joints]),
            np.array([j.max_acceleration for j in info.joints]),
            PERIOD,
        )
        self.q: FloatArray = np.array(info.home, dtype=float)
        self.feed = Feed(None)
        self.reports = 0
        self.now = 0.0
        self.velocity: FloatArray = np.zeros(self.q.size)  # as the robot reports it
        self.action = MouseJog(
            "mouse:m",
            controller,
            self.kinematics,
            cast(InputClient, self.feed),
            cartesian=True,
            frame="base",
            joints=[0, 1, 2, 3, 4, 5],
            speeds=np.array([LINEAR_SPEED] * 3 + [ANGULAR_SPEED] * 3),
            tcp_cap=MANUAL_TCP_SPEED,
            window=0.1,
            on_button=lambda _: None,
        )

    def robot(self) -> RobotState:
        return RobotState(
            seqno=0,
            ts=0.0,
            command_mode=CommandMode.velocity_command,
            operational_mode=OperationalMode.manual_reduced_speed,
            flags=RobotFlags(enabled=True, ready=True, homed=True),
            joint_position=self.q.tolist(),
            joint_velocity=self.velocity.tolist(),
            joint_position_command=self.q.tolist(),
            tcp_pose=self.kinematics.tcp_pose(self.q),
            speed_ratio=1.0,
        )

    def run(self, axes: list[float] | None, cycles: int) -> list[Streamed | None]:
        """`cycles` of the jog loop, the mouse reporting `axes` at each (None: gone); the
        joints follow every velocity commanded, and a halt stops them where they are."""
        sent = []
        for _ in range(cycles):
            if axes is None:
                self.feed.state = None
            else:
                self.reports += 1
                self.feed.state = InputState(
                    seqno=self.reports, ts=self.now, axes=axes, connected=True
                )
            command = self.action.tick(self.robot(), self.now)
            if isinstance(command, VelocityCommand):
                self.q = self.q + np.array(command.velocity) * PERIOD
            sent.append(command)
            self.now += PERIOD
        return sent

    def tcp(self) -> FloatArray:
        return np.array(self.kinematics.tcp(self.q).translation, dtype=float)


def moving(sent: list[Streamed | None]) -> bool:
    return any(isinstance(c, VelocityCommand) and np.abs(c.velocity).max() > 1e-9 for c in sent)


def test_a_mouse_that_goes_away_halts_once_and_its_binding_waits_for_it() -> None:
    cell = Cell()
    cell.run(AT_REST, 5)
    assert moving(cell.run(PUSHED, 50))  # bound and driving
    sent = cell.run(None, 30)  # its driver restarts: the link is down
    assert isinstance(sent[0], Halt) and sent[0].tag == "mouse:m:halt"
    assert sent[1:] == [None] * 29  # halted once, then nothing while it is away
    assert not cell.action.done  # the binding (the switch) stays
    assert cell.action.held()[0] == "mouse_away"
    # A mouse unplugged while its driver runs says so in its state: the same.
    cell.feed.state = InputState(seqno=1, ts=0.0, axes=AT_REST, connected=False)
    assert cell.action.tick(cell.robot(), cell.now) is None
    assert cell.action.held()[0] == "mouse_away" and not cell.action.done


def test_a_mouse_back_with_its_cap_pushed_moves_nothing_until_it_was_let_go() -> None:
    cell = Cell()
    cell.run(AT_REST, 5)
    cell.run(PUSHED, 50)
    cell.run(None, 10)
    here = cell.tcp()
    # Back, its cap pushed all the while (a hand on it, or stuck): nothing moves.
    sent = cell.run(PUSHED, 200)
    assert not moving(sent)
    assert np.allclose(cell.tcp(), here, atol=1e-9)
    assert cell.action.held()[0] == "mouse_not_at_rest"
    assert not cell.action.done
    # Let go, then pushed anew: that deliberate deflection drives it again.
    assert not moving(cell.run(AT_REST, 5))
    assert cell.action.held() == ("", "")
    assert moving(cell.run(PUSHED, 50))
    moved = cell.tcp() - here
    assert moved[0] > 0.005, moved  # to the right, as pushed


def test_a_mouse_bound_with_its_cap_pushed_drives_only_after_it_was_let_go() -> None:
    cell = Cell()
    assert not moving(cell.run(PUSHED, 100))
    assert cell.action.held()[0] == "mouse_not_at_rest"
    cell.run(AT_REST, 3)
    assert moving(cell.run(PUSHED, 20))


def test_a_mouse_back_while_the_halt_still_brakes_leaves_the_halt_to_it() -> None:
    """Review of issue 32: seeded from the braking robot's velocity, the binding streamed
    commands again (out of the driver's halt) before anyone touched the mouse."""
    cell = Cell()
    cell.run(AT_REST, 5)
    cell.run(PUSHED, 50)
    cell.run(None, 1)  # gone: halted
    cell.velocity = np.full(cell.q.size, 0.2)  # the halt still braking when it comes back
    assert cell.run(AT_REST, 20) == [None] * 20  # the halt goes on undisturbed
    pushed = cell.run(PUSHED, 1)[0]
    assert isinstance(pushed, VelocityCommand)
    reach = np.array([j.max_acceleration for j in load_robot_info("ur5").joints]) * PERIOD
    assert np.all(np.abs(pushed.velocity) <= reach + 1e-12)  # from rest, not from the braking
