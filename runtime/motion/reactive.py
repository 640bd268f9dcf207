"""A reactive move ("move with avoidance"): no plan; each cycle the TCP is steered toward the
goal pose and the velocity QP keeps every part clear of obstacles and of the other robots
as they move now. It arrives, or it stops where it cannot get nearer (blocked)."""

from __future__ import annotations

import asyncio
import contextlib
import time

import numpy as np
import pinocchio as pin

from openpendant.runtime.cell.mirror import MAX_AGE, MirrorConstraint
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.interfaces.robot import CommandMode, CommandModeRequest, VelocityCommand
from openpendant.runtime.motion.executor import MoveFailed, check_faults
from openpendant.runtime.robotics.velocity import VelocityController

PERIOD = 0.01  # s
GAIN = 3.0  # 1/s: how fast the remaining error is closed near the goal
LINEAR_SPEED = 0.5  # m/s at speed 1.0
ANGULAR_SPEED = 1.0  # rad/s at speed 1.0
ARRIVED = (1e-4, 1e-3)  # m, rad
SETTLED = 1e-3  # rad/s: joints slower than this have stopped
PROGRESS = 1e-3  # m: getting nearer by less than this ...
BLOCKED_AFTER = 1.5  # s: ... for this long means blocked
# s: the driver stops by itself if the commands stop (as long as the jog's: a stalled
# host must not stop a move that still has time)
COMMAND_TIMEOUT = 0.2


class ReactiveExecution:
    def __init__(
        self,
        link: RobotClient,
        controller: VelocityController,
        avoidance: MirrorConstraint,
        goal: pin.SE3,
        speed: float,
        tcp_cap: float | None,
        claim: str | None = None,
    ) -> None:
        self.link = link
        self.claim = claim  # the caller's (a run's): its commands live only as long
        self.controller = controller
        self.avoidance = avoidance
        self.goal = goal
        self.speed = speed
        self.tcp_cap = tcp_cap
        self.progress = 0.0
        self.generation = -1
        self.paused = False
        self._cancel = asyncio.Event()

    def cancel(self) -> None:
        self._cancel.set()

    async def pause(self, paused: bool) -> None:
        """Paused, it steers nowhere: the robot slows to a stop under its limits and waits."""
        self.paused = paused

    async def run(self) -> None:
        self.generation = self.link.generation  # the move ends with the link it began on
        if self.claim is None:
            await self.link.ensure_mode(CommandMode.velocity_command, self.generation)
        else:  # a call: it waits for the run's claim on its way, which the stream will need
            mode = CommandModeRequest(mode=CommandMode.velocity_command)
            await self.link.set_command_mode(mode, self.generation, claim=self.claim)
        try:
            await self._steer()
        except BaseException:
            await self.link.halt("motion: stop")
            raise
        await self._send(np.zeros(len(self.link.info.joints)))

    async def _steer(self) -> None:
        kinematics = self.controller.kinematics
        start = self._error(
            kinematics.tcp(np.array(self.link.current(self.generation).joint_position))
        )
        first = max(float(np.linalg.norm(start[:3])), 1e-9)
        best, best_at = np.inf, time.monotonic()
        previous: np.ndarray | None = None
        next_tick = last_tick = time.monotonic()
        while True:
            if self._cancel.is_set():
                raise MoveFailed("cancelled", code="cancelled")
            state = self.link.current(self.generation)
            check_faults(state)
            q = np.array(state.joint_position_command)
            error = self._error(kinematics.tcp(q))
            distance = float(np.linalg.norm(error[:3]))
            self.progress = float(np.clip(1.0 - distance / first, 0.0, 1.0))
            turned = float(np.linalg.norm(error[3:]))
            moving = np.max(np.abs(state.joint_velocity)) > SETTLED
            if distance < ARRIVED[0] and turned < ARRIVED[1] and not moving:
                self.progress = 1.0
                return
            now = time.monotonic()
            # A late loop: the other robots are met that much further ahead.
            self.avoidance.horizon = float(np.clip(now - last_tick, 2 * PERIOD, MAX_AGE))
            last_tick = now
            if distance < best - PROGRESS or self.paused:
                best, best_at = min(best, distance), now  # a pause is not being blocked
            elif now - best_at > BLOCKED_AFTER:
                raise MoveFailed(self._blocked(distance), code="blocked")
            twist = np.zeros(6) if self.paused else self._twist(error)
            step = self.controller.from_twist(q, twist, self.tcp_cap, previous)
            previous = step.velocity
            await self._send(step.velocity)
            next_tick = max(next_tick + PERIOD, time.monotonic())
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(max(0.0, next_tick - time.monotonic())):
                    await self._cancel.wait()

    def _error(self, tcp: pin.SE3) -> np.ndarray:
        """From the TCP to the goal: [translation, rotation vector], in the base frame."""
        local = pin.log6(tcp.actInv(self.goal))
        rotation = tcp.rotation
        return np.concatenate((rotation @ local.linear, rotation @ local.angular))

    def _twist(self, error: np.ndarray) -> np.ndarray:
        twist = GAIN * error
        for part, limit in ((slice(0, 3), LINEAR_SPEED), (slice(3, 6), ANGULAR_SPEED)):
            norm = float(np.linalg.norm(twist[part]))
            if norm > limit * self.speed:
                twist[part] *= limit * self.speed / norm
        return twist

    def _blocked(self, distance: float) -> str:
        message = f"blocked {distance * 1000:.0f} mm from the goal"
        nearest = self.avoidance.nearest
        if nearest is not None:
            p = nearest.proximity
            message += f": {p.body} is {p.distance * 1000:.0f} mm from {p.other}"
        return message

    async def _send(self, velocity: np.ndarray) -> None:
        command = VelocityCommand(
            velocity=velocity.tolist(), timeout=COMMAND_TIMEOUT, tag="motion:reactive"
        )
        await self.link.stream(command, self.generation, self.claim)
