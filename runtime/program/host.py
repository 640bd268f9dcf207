"""The runtime's answers to one run's sandbox calls. Moves go to the motion service (limits,
collisions, the manual-mode speed cap), tool and I/O to the robot's driver, values to the
variable storage; every command needs the robot's control lease, which the run holds
(the caller's, or its own). Stop halts every robot the run commanded."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import re
import uuid
from collections.abc import Awaitable, Callable
from typing import Any

from runtime.kit.client import ServiceClient
from runtime.kit.errors import NotFound, OpenPendantError
from runtime.links.hub import LinkHub
from runtime.links.robot import RobotLink, robot_link
from runtime.variable_storage.client import StorageClient
from sandbox.supervisor import CallRefused

log = logging.getLogger(__name__)

MOVE_POLL = 5.0  # s per long-poll of a running move
IO_NAME = re.compile(r"^([a-z][a-z0-9_]{0,31})\.(di|do)(\d{1,2})$")
WAYPOINT_TYPES = ("joint_waypoint", "pose_waypoint")
MAX_STORED = 256 * 1024

Handler = Callable[[dict[str, Any]], Awaitable[Any]]


class RunHost:
    def __init__(
        self,
        holder: str,
        devices: ServiceClient,
        motion: ServiceClient,
        storage: StorageClient,
        hub: LinkHub,
        *,
        robot: str | None,
        leases: dict[str, str],
        on_lease: Callable[[], None] | None = None,
    ) -> None:
        self.holder = holder
        self.hub = hub
        self.devices = devices
        self.motion = motion
        self.storage = storage
        self.robot = robot
        self.given = dict(leases)
        self.acquired: dict[str, str] = {}
        self.on_lease = on_lease  # a lease was taken: the run's record is written again
        self.closed = False
        self.commanded: list[str] = []
        self.speed = 0.5
        # Named on each move: the motion service refuses the run's moves once it is stopped,
        # even one whose request is still on its way when the stop arrives.
        self.caller = f"run-{uuid.uuid4().hex}"
        self.halted = False
        self._drivers: dict[str, RobotLink] = {}
        self._renewer: asyncio.Task[None] | None = None
        self.handlers: dict[str, Handler] = {
            "robot.use": self._use,
            "robot.move": self._move,
            "robot.move_relative": self._move_relative,
            "robot.speed": self._speed,
            "robot.joints": self._joints,
            "robot.tcp": self._tcp,
            "robot.tool": self._tool,
            "robot.home": self._home,
            "waypoint.check": self._waypoint,
            "io.set": self._io_set,
            "io.get": self._io_get,
            "store.get": self._store_get,
            "store.set": self._store_set,
        }

    async def call(self, fn: str, args: dict[str, Any]) -> Any:
        if self.halted:
            raise CallRefused("the program was stopped", "stopped")
        handler = self.handlers.get(fn)
        if handler is None:
            raise CallRefused(f"unknown program function {fn[:40]!r}", "unknown_function")
        try:
            return await handler(args)
        except OpenPendantError as exc:
            raise CallRefused(exc.message, exc.code) from None
        except (KeyError, TypeError, ValueError) as exc:
            raise CallRefused(f"malformed request to {fn}: {exc}", "bad_call") from None

    async def halt(self) -> None:
        """Stop wins: each robot halts at once over its link; the motion service drops the
        move, and any later one of this run."""
        self.halted = True
        robots = list(self.commanded)
        tag = f"{self.holder} stopped"
        # First one message per robot on the link socket, no answer awaited: within a
        # control cycle of the stop. Then the round trips.
        for robot in robots:
            try:
                await self.hub.halt(robot, tag)
            except OpenPendantError as exc:
                log.warning("could not halt %s over its link: %s", robot, exc.message)
        calls = [
            self.motion.post(f"/motion/robots/{robot}/stop", headers=self._caller)
            for robot in robots
        ]
        for result in await asyncio.gather(*calls, return_exceptions=True):
            if isinstance(result, Exception):
                log.warning("halting: %s", result)

    async def pause_motion(self, paused: bool) -> None:
        """Pause (a controlled stop along its path) or resume this run's move on each robot
        it commands; a robot with no move of this run has nothing to do."""
        for robot in self.commanded:
            headers = dict(self._caller)
            token = self.given.get(robot) or self.acquired.get(robot)
            if token is not None:
                headers["X-Lease-Token"] = token
            verb = "pause" if paused else "resume"
            try:
                await self.motion.post(f"/motion/robots/{robot}/{verb}", headers=headers)
            except OpenPendantError as exc:
                if exc.code not in ("not_running", "not_yours"):
                    log.warning("could not %s %s: %s", verb, robot, exc.message)

    @property
    def _caller(self) -> dict[str, str]:
        return {"X-Caller": self.caller}

    async def close(self) -> None:
        self.closed = True
        if self._renewer is not None:
            self._renewer.cancel()
        for link in self._drivers.values():
            with contextlib.suppress(OpenPendantError):
                await link.unclaim()
        for robot, token in self.acquired.items():
            with contextlib.suppress(OpenPendantError):
                await self.devices.delete(
                    f"/devices/{robot}/lease", headers={"X-Lease-Token": token}
                )

    # Robots ---------------------------------------------------------------------------------

    async def _active(self) -> str:
        if self.robot is None:
            robots = [
                d["local_name"]
                for d in await self.devices.get("/devices")
                if d.get("kind") == "robot"
            ]
            if len(robots) != 1:
                raise CallRefused(
                    "choose the robot with a 'use robot' block first", "no_robot_selected"
                )
            self.robot = robots[0]
        return self.robot

    async def _use(self, args: dict[str, Any]) -> None:
        name = str(args["robot"])
        try:
            details = await self.devices.get(f"/devices/{name}")
        except NotFound:
            raise CallRefused(f"there is no robot {name!r}", "unknown_device") from None
        if details.get("kind") != "robot":
            raise CallRefused(f"{name} is a {details.get('kind')}, not a robot", "not_a_robot")
        self.robot = name

    async def _token(self, robot: str) -> str:
        """The lease this run commands `robot` under, taken on first use."""
        token = self.given.get(robot) or self.acquired.get(robot)
        if token is None:
            granted = await self.devices.post(
                f"/devices/{robot}/lease", json={"holder": self.holder}
            )
            token = str(granted["token"])
            self.acquired[robot] = token
            if self.on_lease is not None:
                self.on_lease()
            if self._renewer is None:
                self._renewer = asyncio.create_task(self._renew())
        if robot not in self.commanded:
            self.commanded.append(robot)
        return token

    async def _renew(self) -> None:
        """Leases lapse after a while without commands; a run that waits keeps them."""
        while True:
            await asyncio.sleep(5.0)
            for robot, token in list(self.acquired.items()):
                with contextlib.suppress(OpenPendantError):
                    await self.devices.post(
                        f"/devices/{robot}/lease/check", headers={"X-Lease-Token": token}
                    )

    async def _driver(self, robot: str, token: str) -> RobotLink:
        await self.devices.post(f"/devices/{robot}/lease/check", headers={"X-Lease-Token": token})
        return await self._claimed(robot)

    async def _claimed(self, robot: str) -> RobotLink:
        """The robot's link, claimed for this run: if the program service dies, the device
        manager halts the robot."""
        link = self._drivers.get(robot)
        if link is None:
            link = await robot_link(self.hub, robot)
            await link.claim()
            self._drivers[robot] = link
        return link

    async def _ready_to_halt(self, robot: str) -> None:
        try:
            await self._claimed(robot)
        except OpenPendantError as exc:
            log.warning("no link to %s: %s", robot, exc)

    async def _run_move(self, request: dict[str, Any]) -> None:
        robot = await self._active()
        token = await self._token(robot)
        request.setdefault("speed", self.speed)
        request.setdefault("acceleration", self.speed)
        if self.halted:  # stopped while the robot and its lease were looked up
            raise CallRefused("the program was stopped", "stopped")
        start = self.motion.post(
            f"/motion/robots/{robot}/moves",
            json=request,
            headers={"X-Lease-Token": token, **self._caller},
        )
        if robot in self._drivers:
            status = await start
        else:  # the link is made while the move is planned, not before
            status, _ = await asyncio.gather(start, self._ready_to_halt(robot))
        while status["state"] in ("planning", "running", "paused"):
            status = await self.motion.get(
                f"/motion/moves/{status['id']}",
                params={"wait": MOVE_POLL},
                timeout=MOVE_POLL + 5.0,
            )
        if status["state"] != "finished":
            message = status.get("message") or f"the move was {status['state']}"
            raise CallRefused(message, status.get("code") or str(status["state"]))

    async def _move(self, args: dict[str, Any]) -> None:
        kind = args["kind"]
        if kind not in ("joint", "linear"):
            raise CallRefused(f"unknown move kind {kind!r}", "bad_call")
        await self._run_move({"kind": kind, "target": args["target"]})

    async def _move_relative(self, args: dict[str, Any]) -> None:
        await self._run_move(
            {"kind": "relative", "offset": args["offset"], "offset_frame": args["frame"]}
        )

    async def _home(self, _: dict[str, Any]) -> None:
        robot = await self._active()
        details = await self.devices.get(f"/devices/{robot}")
        home = details["info"]["info"]["home"]
        await self._run_move({"kind": "joint", "target": {"joints": home}})

    async def _speed(self, args: dict[str, Any]) -> None:
        ratio = float(args["ratio"])
        if not 0 < ratio <= 1:
            raise CallRefused("speed must be between 1 and 100 %", "invalid_value")
        self.speed = ratio

    async def _state(self) -> dict[str, Any]:
        robot = await self._active()
        state: dict[str, Any] = await self.devices.get(f"/devices/{robot}/state")
        if not state:
            raise CallRefused(f"no state from {robot}", "device_disconnected")
        return state

    async def _joints(self, _: dict[str, Any]) -> list[float]:
        return [float(v) for v in (await self._state())["joint_position"]]

    async def _tcp(self, _: dict[str, Any]) -> Any:
        return (await self._state())["tcp_pose"]

    async def _tool(self, args: dict[str, Any]) -> None:
        robot = await self._active()
        driver = await self._driver(robot, await self._token(robot))
        await driver.call("POST", "/tool", {"open": bool(args["open"])})

    # Waypoints, I/O, stored values ----------------------------------------------------------

    async def _waypoint(self, args: dict[str, Any]) -> dict[str, str]:
        name = str(args["name"])
        try:
            variable = await self.storage.get(name)
        except NotFound:
            raise CallRefused(f"there is no waypoint {name!r}", "unknown_waypoint") from None
        if variable.type not in WAYPOINT_TYPES:
            raise CallRefused(f"{name} is a {variable.type}, not a waypoint", "not_a_waypoint")
        return {"type": variable.type}

    def _io(self, name: str) -> tuple[str, str, int]:
        match = IO_NAME.match(name)
        if match is None:
            raise CallRefused(
                f"I/O names look like robot.do0 or robot.di3, not {name[:40]!r}", "unknown_io"
            )
        return match.group(1), match.group(2), int(match.group(3))

    async def _io_set(self, args: dict[str, Any]) -> None:
        robot, kind, index = self._io(str(args["name"]))
        if kind != "do":
            raise CallRefused(f"{args['name']} is an input; only outputs can be set", "read_only")
        driver = await self._driver(robot, await self._token(robot))
        await driver.call("PUT", f"/digital_outputs/{index}", {"value": bool(args["value"])})

    async def _io_get(self, args: dict[str, Any]) -> bool:
        robot, kind, index = self._io(str(args["name"]))
        state = await self.devices.get(f"/devices/{robot}/state")
        values = state.get("digital_inputs" if kind == "di" else "digital_outputs", [])
        if index >= len(values):
            raise CallRefused(f"{robot} has no {kind}{index}", "unknown_io")
        return bool(values[index])

    async def _store_get(self, args: dict[str, Any]) -> dict[str, Any]:
        variable = await self.storage.get(str(args["name"]))
        return {"type": variable.type, "value": variable.value}

    async def _store_set(self, args: dict[str, Any]) -> None:
        value = args["value"]
        kind = args.get("type") or _type_of(value)
        await self.storage.put(str(args["name"]), kind, value)


def _type_of(value: Any) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "list"
    return "json"
