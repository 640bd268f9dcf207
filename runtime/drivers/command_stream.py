"""One `/command/ws` socket of a robot driver: streamed commands applied in order.

A plain stream halts the robot when it closes, if it commanded anything. A *session* stream
(first message `{"type": "session", "timeout": s}`) is the runtime's link to this robot:
the robot halts when it closes, or when no message (commands or keepalives) arrives for
`timeout` s. A silent session is then closed, never resumed: commands a lost network held
back must not move the robot when the network returns; the runtime opens a new session.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from typing import Any

from fastapi import WebSocket
from pydantic import ValidationError
from starlette.websockets import WebSocketDisconnect

from openpendant.runtime.drivers.command_log import CommandLog
from openpendant.runtime.interfaces.endpoints import stream_commands
from openpendant.runtime.interfaces.robot import CommandMode
from openpendant.runtime.interfaces.robot_driver import RobotDriver
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import OpenPendantError

log = logging.getLogger(__name__)

MIN_SESSION_TIMEOUT = 0.05
MAX_SESSION_TIMEOUT = 5.0
MAX_PENDING_REPLIES = 100
SILENT_SESSION = 4000  # close code: the session went silent and the robot was halted
# The command streams open in this process (a driver process serves one device).
OPEN: set[CommandStream] = set()


class CommandStream:
    def __init__(self, driver: RobotDriver, log: CommandLog) -> None:
        self.driver = driver
        self.log = log
        self.session_timeout: float | None = None
        self.commanded = False
        self._replies: asyncio.Queue[str] = asyncio.Queue(MAX_PENDING_REPLIES)

    async def serve(self, ws: WebSocket) -> None:
        await ws.accept()
        sender = asyncio.create_task(self._send_replies(ws))
        silent = False
        OPEN.add(self)
        try:
            silent = await self._receive(ws)
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass
        finally:
            OPEN.discard(self)
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError):
                await sender
            if self.session_timeout is not None or self.commanded:
                # A stream that drops must not leave the robot coasting until its timeout.
                reason = "session silent" if silent else "command stream closed"
                await self._halt(reason)
            with contextlib.suppress(RuntimeError, OSError, WebSocketDisconnect):
                await ws.close(code=SILENT_SESSION if silent else 1000)

    async def _receive(self, ws: WebSocket) -> bool:
        """Applies messages until the peer leaves (False) or a session goes silent (True)."""
        while True:
            try:
                async with asyncio.timeout(self.session_timeout):
                    text = await ws.receive_text()
            except TimeoutError:
                log.warning(
                    "runtime session silent for %.0f ms: halting and closing it",
                    (self.session_timeout or 0.0) * 1000,
                )
                return True
            await self._apply(text)

    async def _apply(self, text: str) -> None:
        try:
            message = json.loads(text)
        except ValueError:
            self._reply(None, OpenPendantError("message is not JSON", code="bad_message"))
            return
        ident = message.get("id") if isinstance(message, dict) else None
        try:
            await self._dispatch(message)
        except OpenPendantError as exc:
            self._reply(ident, exc)

    async def _dispatch(self, message: Any) -> None:
        if not isinstance(message, dict):
            raise OpenPendantError("a command must be a JSON object", code="bad_message")
        kind = message.get("type")
        if kind == "keepalive":
            return
        if kind == "session":
            timeout = message.get("timeout")
            if not isinstance(timeout, int | float) or not (
                MIN_SESSION_TIMEOUT <= timeout <= MAX_SESSION_TIMEOUT
            ):
                raise OpenPendantError(
                    f"a session timeout is {MIN_SESSION_TIMEOUT} to {MAX_SESSION_TIMEOUT} s",
                    code="invalid_request",
                    status=422,
                )
            self.session_timeout = float(timeout)
            return
        await dispatch_stream_command(self.driver, message, self.log)
        self.commanded = True

    def _reply(self, ident: Any, exc: OpenPendantError) -> None:
        body: dict[str, Any] = {"type": "error", **exc.body()}
        if isinstance(ident, int | str):
            body["id"] = ident
        with contextlib.suppress(asyncio.QueueFull):  # a peer that stops reading loses errors
            self._replies.put_nowait(json.dumps(body))

    async def _send_replies(self, ws: WebSocket) -> None:
        while True:
            await ws.send_text(await self._replies.get())

    async def _halt(self, reason: str) -> None:
        if self.driver.status().command_mode is CommandMode.halt:
            return  # halted already
        try:
            await self.driver.halt()
        except OpenPendantError as exc:
            log.warning("halt on %s failed: %s", reason, exc.message)
            return
        self.log.record("halt", reason)


async def dispatch_stream_command(driver: RobotDriver, message: Any, log: CommandLog) -> None:
    """One streamed command: `{"type": <the endpoint's stream type>, ...its body}`."""
    if not isinstance(message, dict):
        raise OpenPendantError("a command must be a JSON object", code="bad_message")
    kind = message.get("type")
    ep = stream_commands(type(driver)).get(kind) if isinstance(kind, str) else None
    if ep is None:
        raise OpenPendantError(f"unknown command type {str(kind)[:40]!r}", code="bad_message")
    fields = {k: v for k, v in message.items() if k not in ("type", "id")}
    args: tuple[Any, ...] = ()
    if ep.body is not None:
        try:
            args = (ep.body.model_validate(fields),)
        except ValidationError as exc:
            text, _ = describe_validation_errors(exc.errors())
            raise OpenPendantError(text, code="invalid_request", status=422) from exc
    await getattr(driver, ep.name)(*args)
    label, tag = ep.describe(args)
    if tag is None and isinstance(fields.get("tag"), str):
        tag = fields["tag"][:64]  # a halt's reason
    log.record(label, tag)
