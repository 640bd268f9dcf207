"""A service's handle on one robot, over the device manager's one link to it: the newest
fresh state, ordered commands on the robot's session, calls, halt. Whatever a service
starts on a robot (a jog, a move) names the link generation it began on; when that link is
lost the next one refuses it, so it never continues by itself."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from runtime.interfaces.input import InputState
from runtime.interfaces.robot import CommandMode, RobotInfo, RobotState
from runtime.kit.errors import OpenPendantError, RobotError, Unavailable
from runtime.links.hub import DeviceView, LinkHub, Refusal

READY_TIMEOUT = 2.0


class RobotLink:
    def __init__(self, hub: LinkHub, view: DeviceView) -> None:
        self.hub = hub
        self.view = view
        self.name = view.name
        self._info: RobotInfo | None = None
        self._info_source: dict[str, Any] | None = None
        # The mode this service last set, and on which link. Right after a halt the state
        # can still show the old mode, so the state alone cannot say if a switch is needed.
        self._mode: tuple[CommandMode, int] | None = None
        self._on_error: Refusal | None = None
        view.on_refused = self._refused

    @property
    def info(self) -> RobotInfo:
        source = self.view.info
        if source is None:
            raise Unavailable(
                f"{self.name} has not described itself yet", code="device_disconnected"
            )
        if source is not self._info_source:
            self._info = RobotInfo.model_validate(source["info"])
            self._info_source = source
        assert self._info is not None
        return self._info

    @property
    def generation(self) -> int:
        return self.view.generation

    @property
    def alive(self) -> bool:
        try:
            self.hub.state_text(self.view)
        except OpenPendantError:
            return False
        return True

    @property
    def on_error(self) -> Refusal | None:
        return self._on_error

    @on_error.setter
    def on_error(self, handler: Refusal | None) -> None:
        self._on_error = handler

    def _refused(self, error: dict[str, Any]) -> None:
        self._mode = None  # a refusal may mean the mode changed under us
        if self._on_error is not None:
            self._on_error(error)

    async def ready(self, timeout: float = READY_TIMEOUT) -> RobotLink:
        """Waits for a fresh state; raises why there is none."""
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self.view.ready.wait()
        self.current()
        return self

    def current(self, generation: int | None = None) -> RobotState:
        """The newest state, if it is fresh (and on `generation`, if given)."""
        text = self.hub.state_text(self.view, generation)
        view = self.view
        if view.parsed is None:
            view.parsed = RobotState.model_validate_json(text)
        state: RobotState = view.parsed
        return state

    def latest(self) -> RobotState | None:
        """The newest state however old, or None (for a world mirror that places others)."""
        try:
            return self.current()
        except OpenPendantError:
            return None

    # Commands --------------------------------------------------------------------------------

    async def send(self, command: dict[str, Any], generation: int | None = None) -> None:
        """One streamed command on the robot's session; refusals come back through on_error."""
        if command.get("type") == "halt":
            self._mode = None
        gen = self.generation if generation is None else generation
        await self.hub.send(self.name, gen, command)

    async def halt(self, tag: str | None = None) -> None:
        """Stop always wins: on whatever link to the robot is live."""
        self._mode = None
        await self.hub.halt(self.name, tag)

    async def ensure_mode(self, mode: CommandMode, generation: int | None = None) -> None:
        """Switch the driver's mode ahead of the commands that need it, on the same ordered
        session, without waiting for a round trip; a refusal comes back through on_error."""
        gen = self.generation if generation is None else generation
        if self._mode == (mode, gen) and self.current(gen).command_mode is mode:
            return
        await self.send({"type": "command_mode", "mode": mode.value}, gen)
        self._mode = (mode, gen)

    def forget_mode(self) -> None:
        self._mode = None

    async def call(
        self, method: str, path: str, body: Any = None, generation: int | None = None
    ) -> Any:
        gen = self.generation if generation is None else generation
        status, content = await self.hub.call(self.name, gen, method, path, body)
        if status < 400:
            return content
        error = content.get("error", {}) if isinstance(content, dict) else {}
        message = str(error.get("message") or f"{method} {path} failed ({status})")
        code = str(error.get("code") or "device_error")
        if status == 409:
            raise RobotError(message, code=code)
        raise OpenPendantError(message, code=code, status=status)

    async def claim(self) -> None:
        """Halt this robot if this service goes away (a program run's robots)."""
        await self.hub.claim(self.name, self.generation)

    async def unclaim(self) -> None:
        await self.hub.unclaim(self.name)


class InputLink:
    """An input device (a 3D mouse) over its link: its newest fresh state, or None."""

    def __init__(self, hub: LinkHub, view: DeviceView) -> None:
        self.hub = hub
        self.view = view
        self.name = view.name

    @property
    def state(self) -> InputState | None:
        try:
            text = self.hub.state_text(self.view)
        except OpenPendantError:
            return None
        if self.view.parsed is None:
            self.view.parsed = InputState.model_validate_json(text)
        state: InputState = self.view.parsed
        return state

    async def ready(self, timeout: float = READY_TIMEOUT) -> InputLink:
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self.view.ready.wait()
        self.hub.state_text(self.view)
        return self


async def robot_link(hub: LinkHub, name: str) -> RobotLink:
    """The link to an added robot (one per service), once its state is streaming."""
    view = await hub.watch(name)
    link = hub.handles.get(("robot", name))
    if not isinstance(link, RobotLink):
        link = hub.handles[("robot", name)] = RobotLink(hub, view)
    return await link.ready()


async def input_link(hub: LinkHub, name: str) -> InputLink:
    view = await hub.watch(name)
    link = hub.handles.get(("input", name))
    if not isinstance(link, InputLink):
        link = hub.handles[("input", name)] = InputLink(hub, view)
    return await link.ready()
