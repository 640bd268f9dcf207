"""The runtime's side of one run: what the run's sandbox calls are answered with, and what the
answers may use. Every command needs the device's control lease, which the run holds (the
caller's, or one it takes); moves go to the motion service (limits, collisions, the
manual-mode speed cap). Stop halts every device the run commanded.

The answers themselves are the blocks' handlers (`Block.handlers` of the plugins, the
built-in ones in `blockly_blocks/<category>/handlers.py`): `async def handler(run, args)`,
with `run` this host (`runtime/program/calls.py`)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import uuid
from collections.abc import Awaitable, Callable
from functools import cache
from typing import Any

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.clients.robot import RobotClient
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.words import words
from openpendant.runtime.motion.client import MotionClient, MoveRequest, MoveState
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.sandbox.supervisor import CallRefused

log = logging.getLogger(__name__)

MOVE_POLL = 5.0  # s per long-poll of a running move
LEASE_RENEWAL = 5.0  # s: a run that waits keeps its leases

Handler = Callable[["RunHost", dict[str, Any]], Awaitable[Any]]


@cache
def handlers() -> dict[str, Handler | str]:
    """Every block's runtime calls, by name: a function, or its "module:attribute" reference
    (resolved on each call, so a plugin that cannot load fails only its own blocks)."""
    found: dict[str, Handler | str] = {}
    for block in registry().blocks.values():
        found.update(block.handlers)
    return found


class RunHost:
    def __init__(
        self,
        holder: str,
        devices: Devices,
        motion: MotionClient,
        storage: StorageClient,
        *,
        robot: str | None,
        leases: dict[str, str],
        on_lease: Callable[[], None] | None = None,
        program: str = "",
    ) -> None:
        self.holder = holder
        self.program = program or holder  # whose stored values are counted together
        self.devices = devices
        self.motion = motion
        self.storage = storage
        self.robot = robot  # the robot the robot blocks command ("use robot")
        self.given = dict(leases)
        self.acquired: dict[str, str] = {}
        self.on_lease = on_lease  # a lease was taken: the run's record is written again
        self.closed = False
        self.commanded: list[str] = []  # every device the run took or used a lease of
        self.robots: list[str] = []  # ... of which the robots
        self.speed = 0.5
        self.gripper_force: dict[str, float] = {}  # N, set by a block for the following closes
        # Each device's kind, asked once per run (an input waited on is read every few ms).
        self.kinds: dict[str, str] = {}
        # Named on each move: the motion service refuses the run's moves once it is stopped,
        # even one whose request is still on its way when the stop arrives.
        self.caller = f"run-{uuid.uuid4().hex}"
        self.halted = False
        self._claimed: dict[str, RobotClient] = {}
        self._others: dict[str, DeviceClient[Any]] = {}  # commanded devices that are not robots
        self._renewer: asyncio.Task[None] | None = None

    async def call(self, fn: str, args: dict[str, Any]) -> Any:
        self.refuse_if_stopped()
        found = handlers().get(fn)
        if found is None:
            raise CallRefused(
                f"unknown program function {fn[:40]!r}",
                "unknown_function",
                words("run.unknown_function", name=fn[:40]),
            )
        try:
            handler: Handler = resolve(found) if isinstance(found, str) else found
        except Exception as exc:  # a plugin that cannot be loaded fails its block, not the run
            log.warning("the handler of %s cannot be loaded: %s", fn, exc)
            raise CallRefused(
                f"{fn} is not available: {exc}",
                "plugin_failed",
                words("run.function_failed", name=fn, error=str(exc)),
            ) from None
        try:
            result = await handler(self, args)
        except CallRefused:
            raise
        except OpenPendantError as exc:
            raise CallRefused(exc.message, exc.code, exc.words) from None
        except (KeyError, TypeError, ValueError) as exc:
            raise CallRefused(
                f"malformed request to {fn}: {exc}",
                "bad_call",
                words("run.function_failed", name=fn, error=str(exc)),
            ) from None
        except Exception as exc:  # a handler's own bug fails its block; the run gets an answer
            log.exception("the handler of %s failed", fn)
            error = f"{type(exc).__name__}: {exc}"
            raise CallRefused(
                f"{fn} failed: {error}",
                "handler_failed",
                words("run.function_failed", name=fn, error=error),
            ) from None
        finally:
            if self.halted:
                # A command that was on its way when the stop came may reach its device after
                # the stop did: stop what the run commanded once more.
                await self._stop_others()
        return result

    # Stop, pause, the end -------------------------------------------------------------------

    def refuse_if_stopped(self) -> None:
        """Checked again after each await that looks a device up: a stop may have come."""
        if self.halted:
            raise CallRefused("the program was stopped", "stopped", words("run.stopped"))

    async def halt(self) -> None:
        """Stop wins: each robot halts at once over its link; the motion service drops the
        move, and any later one of this run; other devices the run commanded are stopped."""
        self.halted = True
        robots = list(self.robots)
        tag = f"{self.holder} stopped"
        # First one message per robot on the link socket, no answer awaited: within a
        # control cycle of the stop. Then the round trips.
        for robot in robots:
            try:
                await self.devices.halt(robot, tag)
            except OpenPendantError as exc:
                log.warning("could not halt %s over its link: %s", robot, exc.message)
        calls: list[Awaitable[Any]] = [self.motion.stop(r, self.caller) for r in robots]
        calls.append(self._stop_others())
        for result in await asyncio.gather(*calls, return_exceptions=True):
            if isinstance(result, Exception):
                log.warning("halting: %s", result)

    async def _stop_others(self) -> None:
        stops = [_stop(client) for client in self._others.values()]
        for name, result in zip(
            self._others, await asyncio.gather(*stops, return_exceptions=True), strict=True
        ):
            if isinstance(result, Exception):
                log.warning("could not stop %s: %s", name, result)

    async def pause_motion(self, paused: bool) -> None:
        """Pause (a controlled stop along its path) or resume this run's move on each robot
        it commands; a robot with no move of this run has nothing to do."""
        for robot in self.robots:
            try:
                if paused:
                    await self.motion.pause(robot, self.caller)
                else:
                    await self.motion.resume(robot, self._lease_of(robot), self.caller)
            except OpenPendantError as exc:
                if exc.code not in ("not_running", "not_yours"):
                    log.warning("could not pause/resume %s: %s", robot, exc.message)

    async def close(self) -> None:
        self.closed = True
        if self._renewer is not None:
            self._renewer.cancel()
        for link in self._claimed.values():
            with contextlib.suppress(OpenPendantError):
                await link.unclaim(self.caller)
        for device, token in self.acquired.items():
            with contextlib.suppress(OpenPendantError):
                await self.devices.manager.release_lease(device, token)

    # What handlers use ----------------------------------------------------------------------

    async def active_robot(self) -> str:
        """The robot "use robot" chose, or the only robot there is."""
        if self.robot is None:
            robots = await self.devices.robot_names()
            if len(robots) != 1:
                raise CallRefused(
                    "choose the robot with a 'use robot' block first",
                    "no_robot_selected",
                    words("run.no_robot"),
                )
            self.robot = robots[0]
        return self.robot

    async def token(self, device: str) -> str:
        """The lease this run commands `device` under, taken on first use."""
        token = self._lease_of(device)
        if token is None:
            granted = await self.devices.manager.take_lease(device, self.holder)
            token = self.acquired[device] = granted.token
            if self.on_lease is not None:
                self.on_lease()
            if self._renewer is None:
                self._renewer = asyncio.create_task(self._renew())
        if device not in self.commanded:
            self.commanded.append(device)
        return token

    async def robot_client(self, robot: str) -> RobotClient:
        """The robot's client, under this run's lease, claimed for the run: if the program
        service dies, the device manager halts the robot."""
        self._is_robot(robot)
        await self.devices.check_lease(robot, await self.token(robot))
        claimed = await self._claim(robot)
        self.refuse_if_stopped()  # stopped while the robot and its lease were looked up
        return claimed

    async def device(self, name: str, kind: str) -> DeviceClient[Any]:
        """Another kind of device to command, under this run's lease; stopped with the run."""
        client = await self.devices.client(name, kind)
        await self.devices.check_lease(name, await self.token(name))
        self._others[name] = client
        self.refuse_if_stopped()  # stopped while the device and its lease were looked up
        return client

    async def read_device(self, name: str, kind: str) -> DeviceClient[Any]:
        """A device to read from: no lease needed."""
        return await self.devices.client(name, kind)

    async def run_move(self, request: MoveRequest) -> None:
        """One move of the active robot, to its end; raises why it did not finish."""
        robot = await self.active_robot()
        self._is_robot(robot)
        token = await self.token(robot)
        fields = request.model_fields_set
        update = {k: self.speed for k in ("speed", "acceleration") if k not in fields}
        request = request.model_copy(update=update)
        self.refuse_if_stopped()  # stopped while the robot and its lease were looked up
        start = self.motion.start(robot, request, token, self.caller, claim=self.caller)
        if robot in self._claimed:
            status = await start
        else:  # the link is made while the move is planned, not before
            status, _ = await asyncio.gather(start, self._ready_to_halt(robot))
        while status.state in (MoveState.planning, MoveState.running, MoveState.paused):
            status = await self.motion.status(status.id, MOVE_POLL)
        if status.state is not MoveState.finished:
            message = status.message or f"the move was {status.state.value}"
            raise CallRefused(message, status.code or status.state.value, status.words)

    # Leases and claims ----------------------------------------------------------------------

    def _is_robot(self, name: str) -> None:
        if name not in self.robots:
            self.robots.append(name)

    def _lease_of(self, device: str) -> str | None:
        return self.given.get(device) or self.acquired.get(device)

    async def _renew(self) -> None:
        """Leases lapse after a while without commands; a run that waits keeps them."""
        while True:
            await asyncio.sleep(LEASE_RENEWAL)
            for device, token in list(self.acquired.items()):
                with contextlib.suppress(OpenPendantError):
                    await self.devices.manager.check_lease(device, token)

    async def _claim(self, robot: str) -> RobotClient:
        link = self._claimed.get(robot)
        if link is None:
            link = await self.devices.robot(robot)
            await link.claim(self.caller)
            self._claimed[robot] = link
        return link

    async def _ready_to_halt(self, robot: str) -> None:
        try:
            await self._claim(robot)
        except OpenPendantError as exc:
            log.warning("no link to %s: %s", robot, exc)


async def _stop(client: DeviceClient[Any]) -> None:
    stop = getattr(client, "stop", None)
    if stop is not None:
        await stop()
