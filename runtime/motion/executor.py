"""Running a timed joint path on a robot: uploaded as one trajectory, then watched until it
ends; stopped (halted) on cancel, on a driver fault, when the robot stops following its
setpoint, or when it leaves its planned path (the path monitor)."""

from __future__ import annotations

import asyncio
import contextlib

import numpy as np

from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    JointTrajectory,
    ProtectiveStopRequest,
    RobotState,
    TrajectoryState,
    TrajectoryWaypoint,
)
from openpendant.runtime.kit.errors import OpenPendantError, RobotError
from openpendant.runtime.kit.metrics import PATH_DEVIATIONS
from openpendant.runtime.kit.words import words
from openpendant.runtime.robotics.path_monitor import PathDeviation, PathMonitor
from openpendant.runtime.robotics.timing import TimedPath

WATCH_PERIOD = 0.02  # s
# The robot's position and its setpoint this far apart means it is not following.
MAX_TRACKING_ERROR = 0.05  # rad
START_TOLERANCE = 1e-3  # rad: the plan must start where the robot is


class MoveFailed(OpenPendantError):
    status = 409
    code = "move_failed"


def trajectory(timed: TimedPath) -> JointTrajectory:
    """The timed path as the driver takes it (built unchecked: the driver checks it)."""
    return JointTrajectory.model_construct(
        waypoints=[
            TrajectoryWaypoint.model_construct(
                time_from_start=float(t),
                position=p.tolist(),
                velocity=v.tolist(),
                acceleration=a.tolist(),
            )
            for t, p, v, a in zip(
                timed.times, timed.positions, timed.velocities, timed.accelerations, strict=True
            )
        ]
    )


def check_faults(state: RobotState) -> None:
    """Raise when the robot can no longer move: E-stop, or a fault."""
    if state.flags.estop:
        raise RobotError("E-stop: the move is stopped", code="estop", words=words("robot.estop"))
    if state.flags.error:
        raise RobotError(
            f"robot fault: {state.error_message}",
            code="robot_fault",
            words=words("robot.fault", error=state.error_message),
        )


class Execution:
    def __init__(
        self,
        link: RobotClient,
        timed: TimedPath,
        *,
        mode_ready: bool = False,
        monitor: PathMonitor | None = None,
        claim: str | None = None,
    ) -> None:
        self.link = link
        self.timed = timed
        self.monitor = monitor
        self.claim = claim  # the caller's (a run's): its commands live only as long
        self.mode_ready = mode_ready  # the driver was put in trajectory mode for this move
        self.progress = 0.0
        self.generation = -1
        self.paused = False
        self._uploaded = False
        self._cancel = asyncio.Event()

    def cancel(self) -> None:
        self._cancel.set()

    async def pause(self, paused: bool) -> None:
        """A controlled stop along the path (the driver slows the trajectory's clock to
        zero), or on again from there. Before the upload, the move starts paused."""
        self.paused = paused
        if self._uploaded:
            if paused:
                await self.link.pause_trajectory(generation=self.generation)
            else:
                await self.link.resume_trajectory(generation=self.generation)

    async def run(self) -> None:
        """Returns when the robot has arrived; raises MoveFailed otherwise (robot halted)."""
        # The move belongs to the link it starts on: if that is lost, the move has failed,
        # whatever the next link shows.
        self.generation = self.link.generation
        state = self.link.current(self.generation)
        here = np.array(state.joint_position)
        if np.max(np.abs(here - self.timed.positions[0])) > START_TOLERANCE:
            raise MoveFailed("the robot moved since the move was planned; plan again")
        if len(self.timed.times) < 2:  # already there
            self.progress = 1.0
            return
        gen = self.generation
        if not self.mode_ready or state.command_mode is not CommandMode.trajectory:
            mode = CommandModeRequest(mode=CommandMode.trajectory)
            await self.link.set_command_mode(mode, generation=gen, claim=self.claim)
        try:
            accepted = await self.link.execute_trajectory(
                trajectory(self.timed), generation=gen, claim=self.claim
            )
        except RobotError as exc:
            if exc.code == "wrong_mode":  # something else took the robot since it was set
                raise MoveFailed(f"{exc.message}; plan again", code="wrong_mode") from exc
            raise
        trajectory_id = accepted.id
        self._uploaded = True
        try:
            if self.paused:  # paused while it was planned: it waits at its start
                await self.link.pause_trajectory(generation=gen)
            await self._watch(trajectory_id)
        except BaseException as exc:
            await self.link.halt("motion: stop")
            if isinstance(exc, PathDeviation):
                PATH_DEVIATIONS.labels(self.link.name).inc()
                # As a controller's path monitor would: held until errors are reset, and
                # shown as the robot's fault with the distance.
                with contextlib.suppress(OpenPendantError):
                    await self.link.protective_stop(ProtectiveStopRequest(reason=exc.message))
            raise

    async def _watch(self, trajectory_id: str) -> None:
        while True:
            if self._cancel.is_set():
                raise MoveFailed("cancelled", code="cancelled")
            with contextlib.suppress(TimeoutError):
                # asyncio.timeout, not wait_for: on 3.11 wait_for can lose a cancellation.
                async with asyncio.timeout(WATCH_PERIOD):
                    await self._cancel.wait()
            state = self.link.current(self.generation)
            self._check(state)
            if self.monitor is not None:
                self.monitor.check(np.array(state.joint_position))
            running = state.trajectory
            if running is not None and running.id == trajectory_id:
                # The driver's progress: a pause or the speed override slow the clock.
                self.progress = running.progress
                continue
            status = await self.link.trajectory_status(trajectory_id, generation=self.generation)
            if status.state is TrajectoryState.finished:
                self.progress = 1.0
                return
            if status.state is not TrajectoryState.running:
                raise MoveFailed(f"the robot ended the move: {status.message or status.state}")

    @staticmethod
    def _check(state: RobotState) -> None:
        check_faults(state)
        lag = np.max(
            np.abs(np.array(state.joint_position) - np.array(state.joint_position_command))
        )
        if lag > MAX_TRACKING_ERROR:
            raise MoveFailed(f"the robot is not following its setpoint ({lag:.3f} rad behind)")
