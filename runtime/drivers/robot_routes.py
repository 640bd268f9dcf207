"""A robot driver's ordered command socket (its other routes come from the interface)."""

from __future__ import annotations

from fastapi import APIRouter, WebSocket

from openpendant.runtime.drivers.command_log import CommandLog
from openpendant.runtime.drivers.command_stream import CommandStream
from openpendant.runtime.interfaces.robot_driver import RobotDriver


def command_router(driver: RobotDriver, log: CommandLog) -> APIRouter:
    router = APIRouter()

    @router.websocket("/command/ws")
    async def command_ws(ws: WebSocket) -> None:
        """Streamed commands, one JSON object per message with a `type` (jog_joint,
        velocity_command, position_command, command_mode, halt; session, keepalive); they
        apply in order, and refusals come back on the socket (with the command's `id`)."""
        await CommandStream(driver, log).serve(ws)

    return router
