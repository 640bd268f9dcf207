"""A camera's frame stream: `WS /frames/ws`, each frame a text message (JSON: its seqno, when
it was taken, its size and encoding) then a binary one (the encoded image); the next frame is
taken only after the consumer acknowledges the last with any text message, so a slow consumer
gets the newest frame, never a queue of old ones. A frame the camera cannot take ends the
stream with the reason, as an error message the viewer shows."""

from __future__ import annotations

import contextlib
import json

from fastapi import APIRouter, WebSocket
from starlette.websockets import WebSocketDisconnect

from openpendant.runtime.drivers.command_log import CommandLog
from openpendant.runtime.interfaces.camera import CameraDriver, CaptureRequest, Encoding
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.websocket import send_error


def frames_router(driver: CameraDriver, log: CommandLog) -> APIRouter:
    router = APIRouter()

    @router.websocket("/frames/ws")
    async def frames(ws: WebSocket, encoding: Encoding = "jpeg", quality: int = 80) -> None:
        request = CaptureRequest(encoding=encoding, quality=min(max(quality, 1), 100))
        await ws.accept()
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                try:
                    frame = await driver.frame(request)
                except OpenPendantError as exc:
                    await send_error(ws, exc)
                    await ws.close(code=1011)
                    return
                await ws.send_text(json.dumps(frame.header()))
                await ws.send_bytes(frame.data)
                await ws.receive_text()  # the consumer has drawn it

    return router
