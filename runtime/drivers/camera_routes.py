"""A camera's frame stream: `WS /frames/ws`, each frame a text message (JSON: its seqno, when
it was taken, its size and encoding) then a binary one (the encoded image); the next frame is
taken only after the consumer acknowledges the last with any text message, so a slow consumer
gets the newest frame, never a queue of old ones."""

from __future__ import annotations

import base64
import contextlib
import json

from fastapi import APIRouter, WebSocket
from starlette.websockets import WebSocketDisconnect

from runtime.drivers.command_log import CommandLog
from runtime.interfaces.camera import CameraDriver, CaptureRequest, Encoding


def frames_router(driver: CameraDriver, log: CommandLog) -> APIRouter:
    router = APIRouter()

    @router.websocket("/frames/ws")
    async def frames(ws: WebSocket, encoding: Encoding = "jpeg", quality: int = 80) -> None:
        request = CaptureRequest(encoding=encoding, quality=min(max(quality, 1), 100))
        await ws.accept()
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                image = await driver.capture(request)
                await ws.send_text(json.dumps(image.model_dump(exclude={"data"})))
                await ws.send_bytes(base64.b64decode(image.data))
                await ws.receive_text()  # the consumer has drawn it

    return router
