"""One robot's jogging: runs the current action at 100 Hz over the robot's command stream.
At most one action at a time; a new press replaces the old one."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from openpendant.runtime.clients.robot import Halt, RobotClient
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    OperationalMode,
    ProtectiveStopRequest,
    VelocityCommand,
)
from openpendant.runtime.jog.actions import Action, MouseJog, RampedJog
from openpendant.runtime.kit.errors import OpenPendantError, RobotError
from openpendant.runtime.kit.metrics import PATH_DEVIATIONS
from openpendant.runtime.kit.words import Words, words, words_of
from openpendant.runtime.links.hub import LINK_FAULTS
from openpendant.runtime.robotics.avoidance import SAFETY
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.path_monitor import PathDeviation
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED, Constraint, VelocityController

log = logging.getLogger(__name__)

PERIOD = 0.01


@dataclass
class Ended:
    press: str
    state: str  # "done", "stopped", "halted", "refused"
    reason: str  # short and stable: a code the UI may act on
    message: str = ""  # for people; the reason when empty
    words: Words | None = None  # the message as the UI says it in its language


Listener = Callable[[Ended], None]
# A press whose motion the robot's limits or the avoidance hold back: (press, why or "",
# its words, a code: "held_back", or the 3D mouse's "mouse_away" or "mouse_not_at_rest").
HeldListener = Callable[[str, str, Words | None, str], None]
HELD_SPEED = 1e-3  # rad/s: a fully ramped-up jog commanding less than this is held back
HELD_CLEARANCE = SAFETY + 0.01  # m: nearer than this, the avoidance is what holds it


class Jogger:
    def __init__(
        self, link: RobotClient, kinematics: Kinematics, constraints: list[Constraint] | None = None
    ) -> None:
        self.link = link
        self.kinematics = kinematics
        joints = link.info.joints
        self.controller = VelocityController(
            kinematics,
            np.array([j.max_velocity for j in joints]),
            np.array([j.max_acceleration for j in joints]),
            PERIOD,
            constraints or [],
        )
        self.action: Action | None = None
        self.listener: Listener | None = None
        self.on_held: HeldListener | None = None
        self._held = ""  # why the current press is held back, if it is
        self._wake = asyncio.Event()
        self._halts: set[asyncio.Task[None]] = set()  # halts of refused presses, on their way
        self._task = asyncio.create_task(self._run(), name=f"jog:{link.name}")
        link.on_error = self._refused

    async def close(self) -> None:
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._task
        if self._halts:
            await asyncio.gather(*self._halts, return_exceptions=True)
        if self.link.on_error == self._refused:
            self.link.on_error = None

    def tcp_cap(self) -> float | None:
        state = self.link.current()
        if state.operational_mode is OperationalMode.auto:
            raise RobotError(
                "jogging needs manual mode; the robot is in automatic",
                code="not_manual",
                words=words("robot.not_manual"),
            )
        if state.operational_mode is OperationalMode.manual_full_speed:
            return None
        return MANUAL_TCP_SPEED

    async def start(
        self, action: Action, listener: Listener, on_held: HeldListener | None = None
    ) -> None:
        # The press belongs to the link it began on: if that link is lost, the next one
        # refuses its commands, and it ends.
        action.generation = self.link.generation
        self._require_ready(action)
        previous = self.action
        self.action = None
        self._held = ""
        if previous is not None and previous.press != action.press:
            self._end(previous, "stopped", "replaced by a new press")
        try:
            await self.link.ensure_mode(action.mode, action.generation)
            self.listener = listener
            self.on_held = on_held
            self.action = action
            await self._tick(action)  # the first command goes out now, not at the next cycle
        except Exception:
            # Refused as it began: the cycle must not go on with it, and neither the press
            # it replaced nor its own first command may keep the robot moving.
            if self.action is action:
                self.action = None
            if previous is not None or action.streamed:
                await self._halt_ended(action, "refused")
            raise
        self._wake.set()

    def _require_ready(self, action: Action) -> None:
        flags = self.link.current(action.generation).flags
        if flags.ready:
            return
        # The same codes the driver uses, whichever of the two notices first.
        if flags.estop:
            raise RobotError("the E-stop is engaged", code="estop", words=words("robot.estop"))
        if flags.error:
            message = self.link.current(action.generation).error_message
            raise RobotError(
                f"the robot has an error: {message}",
                code="error",
                words=words("robot.fault", error=message),
            )
        raise RobotError(
            "the robot is not enabled", code="not_enabled", words=words("robot.not_enabled")
        )

    async def _resume_mouse(self, action: MouseJog) -> None:
        """A 3D mouse back after its own halt, pushed anew from rest: a new press, checked as
        one (ready, manual mode, control still held) before its mode is taken again."""
        self._require_ready(action)
        action.tcp_cap = self.tcp_cap()
        if action.recheck is not None:
            await action.recheck()
        action.after_halt = False
        await self.link.ensure_mode(action.mode, action.generation)

    async def stop(self, press: str, reason: str, *, halt: bool, said: Words | None = None) -> None:
        """End a press: on release the robot decelerates under its limits; on a lost deadman
        or a stop request it is halted, and nothing resumes without a new press."""
        action = self.action
        if halt:
            await self.link.halt(tag=f"{press}:halt")
        if action is None or action.press != press:
            return
        if not halt and action.release(time.monotonic()):
            return  # it ramps down along its path and reports when stopped
        self.action = None
        if not halt:
            await self.link.halt(tag=f"{action.press}:release")
        self._end(action, "halted" if halt else "stopped", reason, said=said)

    async def halt_all(self, reason: str) -> None:
        action = self.action
        self.action = None
        await self.link.halt(tag="halt")
        if action is not None:
            self._end(action, "halted", reason)

    async def _brake(self, action: Action) -> None:
        if action.mode is CommandMode.velocity_command:
            zero = [0.0] * len(self.link.info.joints)
            await self.link.stream(
                VelocityCommand(velocity=zero, timeout=0.2, tag=f"{action.press}:release"),
                action.generation,
            )
        else:
            await self.link.halt(tag=f"{action.press}:release")

    async def _halt_ended(self, action: Action, why: str) -> None:
        """A press that ended on a fault or a refusal: what it set moving is halted, and
        nothing moves again until the operator presses again."""
        with contextlib.suppress(OpenPendantError):
            await self.link.halt(tag=f"{action.press}:{why}")

    async def _protective_stop(self, action: Action, reason: str) -> None:
        """The arm left the path that was checked: halted, and a protective stop until
        errors are reset, as the motion service's path monitor does."""
        with contextlib.suppress(OpenPendantError):
            await self.link.halt(tag=f"{action.press}:path_deviation")
        with contextlib.suppress(OpenPendantError):
            await self.link.protective_stop(ProtectiveStopRequest(reason=reason))

    def _end(
        self,
        action: Action,
        state: str,
        reason: str,
        message: str = "",
        said: Words | None = None,
    ) -> None:
        if self.listener is not None:
            self.listener(Ended(action.press, state, reason, message or reason, said))

    def _report_held(self, action: Action, now: float) -> None:
        """Say why a press moves nothing though held (once per change of reason): the
        operator must not be left with "Moving" while the robot stands still."""
        held, said, code = "", None, "held_back"
        if (
            isinstance(action, RampedJog)
            and action.released is None
            and action.level(now) >= 1.0
            and action.previous is not None
            and float(np.max(np.abs(action.previous))) < HELD_SPEED
        ):
            held, said = self.held_reason()
        elif isinstance(action, MouseJog):
            code, held = action.held()
        if held != self._held:
            self._held = held
            if self.on_held is not None:
                self.on_held(action.press, held, said, code)

    def held_reason(self) -> tuple[str, Words]:
        for constraint in self.controller.constraints:
            contact = getattr(constraint, "nearest", None)
            if contact is not None and contact.proximity.distance < HELD_CLEARANCE:
                p = contact.proximity
                distance, clear = round(p.distance * 1000), round(SAFETY * 1000)
                return (
                    f"held back: {p.body} is {distance} mm from {p.other} "
                    f"(the robot keeps {clear} mm clear)",
                    words(
                        "jog.held_near", part=p.body, distance=distance, other=p.other, clear=clear
                    ),
                )
        return "held back by a joint limit or a singularity", words("jog.held_limit")

    def _refused(self, error: dict[str, Any]) -> None:
        """A command was refused (by the driver or the link): the press is over. Its earlier
        commands may have set the robot moving (a velocity the driver keeps until its
        timeout, or longer on a controller that missed a stop), so it is halted."""
        action = self.action
        if action is not None:
            self.action = None
            message = str(error.get("message", "the robot refused"))
            code = str(error.get("code", "refused"))
            fault = code in LINK_FAULTS
            if action.streamed:
                halt = asyncio.get_running_loop().create_task(
                    self._halt_ended(action, "link" if fault else "refused"),
                    name=f"jog-halt:{action.press}",
                )
                self._halts.add(halt)
                halt.add_done_callback(self._halts.discard)
            said = words_of(error.get("words"))
            self._end(action, "halted" if fault else "refused", code, message, said)

    async def _tick(self, action: Action) -> None:
        state = self.link.current(action.generation)
        now = time.monotonic()
        command = action.tick(state, now)
        if command is not None:
            if isinstance(action, MouseJog) and action.after_halt and not isinstance(command, Halt):
                await self._resume_mouse(action)
            action.streamed = True  # before the send: one that fails may have gone out
            await self.link.stream(command, action.generation)
        self._report_held(action, now)
        if action.done and self.action is action:
            self.action = None
            self._end(action, *action.outcome)

    async def _run(self) -> None:
        next_tick = time.monotonic()
        while True:
            if self.action is None:
                await self._wake.wait()
                self._wake.clear()
                next_tick = time.monotonic() + PERIOD  # start() already sent the first
            await asyncio.sleep(max(0.0, next_tick - time.monotonic()))
            next_tick = max(next_tick + PERIOD, time.monotonic())  # late: no catch-up burst
            action = self.action
            if action is None:
                continue
            try:
                await self._tick(action)
            except PathDeviation as exc:
                if self.action is action:
                    self.action = None
                    log.warning("jog on %s ended: %s", self.link.name, exc.message)
                    PATH_DEVIATIONS.labels(self.link.name).inc()
                    await self._protective_stop(action, exc.message)
                    self._end(action, "halted", exc.code, exc.message, exc.words)
            except OpenPendantError as exc:
                if self.action is action:
                    self.action = None
                    if exc.code in LINK_FAULTS:
                        # A lost or stale link: the robot is halted and the press is over;
                        # it never resumes when the link returns.
                        log.warning("jog on %s ended: %s", self.link.name, exc.message)
                        await self._halt_ended(action, "link")
                        self._end(action, "halted", exc.code, exc.message, exc.words)
                    else:
                        if action.streamed:
                            await self._halt_ended(action, "refused")
                        self._end(action, "refused", exc.code, exc.message, exc.words)
            except Exception:
                log.exception("jog cycle failed; halting %s", self.link.name)
                self.action = None
                with contextlib.suppress(OpenPendantError):
                    await self.link.halt(tag="error")
                self._end(action, "halted", "internal error")
