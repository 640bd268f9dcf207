"""A service's live link to one robot driver: the latest state (its state stream), a command
stream (the driver halts the robot if this stream drops), and plain HTTP for the rest."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections.abc import Callable
from typing import Any

import websockets

from runtime.interfaces.robot import CommandMode, RobotInfo, RobotState
from runtime.kit.client import ServiceClient
from runtime.kit.errors import OpenPendantError, RobotError, Unavailable
from runtime.state_feed import StateFeed

log = logging.getLogger(__name__)

ErrorHandler = Callable[[dict[str, Any]], None]


class RobotLink:
    def __init__(self, name: str, url: str, info: RobotInfo) -> None:
        self.name = name
        self.url = url.rstrip("/")
        self.info = info
        self.http = ServiceClient(self.url, timeout=3.0, name=f"robot {name}")
        self.feed = StateFeed(self.url, RobotState, name)
        self.on_error: ErrorHandler | None = None
        self._ws_url = self.url.replace("http://", "ws://", 1)
        self._commands: websockets.ClientConnection | None = None
        self._command_lock = asyncio.Lock()
        self._tasks: list[asyncio.Task[None]] = []
        # The mode this link last set. Right after a halt the cached state can still show
        # the old mode, so the state alone cannot say whether a switch is needed.
        self._mode: CommandMode | None = None

    async def start(self) -> None:
        await self.feed.start()

    async def close(self) -> None:
        await self.feed.close()
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        if self._commands is not None:
            await self._commands.close()
        await self.http.aclose()

    @property
    def alive(self) -> bool:
        return self.feed.alive

    def current(self) -> RobotState:
        state = self.feed.state
        if state is None:
            raise Unavailable(f"no state from {self.name} yet", code="device_disconnected")
        return state

    # Commands -------------------------------------------------------------------------------

    async def open_commands(self) -> None:
        """Opens the command stream ahead of need, so the first command (a halt) is one
        message and not a connection set-up."""
        async with self._command_lock:
            await self._stream()

    async def send(self, command: dict[str, Any]) -> None:
        """One streamed command; refusals come back through `on_error`."""
        if command.get("type") == "halt":
            self._mode = None
        async with self._command_lock:
            stream = await self._stream()
            try:
                await stream.send(json.dumps(command))
            except websockets.WebSocketException as exc:
                self._commands = None
                raise Unavailable(
                    f"lost the command stream to {self.name}", code="device_disconnected"
                ) from exc

    async def _stream(self) -> websockets.ClientConnection:
        if self._commands is None:
            try:
                self._commands = await websockets.connect(
                    f"{self._ws_url}/command/ws", open_timeout=2.0, close_timeout=1.0
                )
            except (OSError, websockets.WebSocketException, TimeoutError) as exc:
                raise Unavailable(
                    f"cannot reach {self.name}: {exc}", code="device_disconnected"
                ) from exc
            self._tasks.append(asyncio.create_task(self._read_errors(self._commands)))
        return self._commands

    async def _read_errors(self, ws: websockets.ClientConnection) -> None:
        with contextlib.suppress(websockets.WebSocketException, OSError):
            async for message in ws:
                body = json.loads(message)
                self._mode = None  # a refusal may mean the mode changed under us
                if self.on_error is not None and isinstance(body, dict):
                    self.on_error(body.get("error", {}))
        if self._commands is ws:
            self._commands = None

    async def halt(self, tag: str | None = None) -> None:
        """Stop always wins: over the stream when it is up, else over HTTP."""
        self._mode = None
        try:
            await self.send({"type": "halt", "tag": tag})
        except OpenPendantError:
            await self.http.post("/halt")

    async def ensure_mode(self, mode: CommandMode) -> None:
        """Switch the driver's mode ahead of the commands that need it, on the same ordered
        stream, without waiting for a round trip; a refusal comes back through on_error."""
        if self._mode is mode and self.current().command_mode is mode:
            return
        await self.send({"type": "command_mode", "mode": mode.value})
        self._mode = mode

    async def call(self, method: str, path: str, body: Any = None) -> Any:
        try:
            return await self.http.request(method, path, json=body)
        except OpenPendantError as exc:
            if exc.status == 409:
                raise RobotError(exc.message, code=exc.code) from exc
            raise
