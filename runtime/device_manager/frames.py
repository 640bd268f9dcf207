"""A camera's live frames for the UI: `WS /devices/{name}/frames/ws` relays the camera's own
`/frames/ws` (signed as this runtime's, as every call to a device is). Frames go down and the
viewer's acknowledgements up, one for one, so the camera takes the next frame only when the
viewer has drawn the last: a slow tablet sees the newest picture, never a queue of old ones."""

from __future__ import annotations

import json
from urllib.parse import urlencode

import websockets
from starlette.websockets import WebSocket

from openpendant.runtime.device_manager.connection import declares
from openpendant.runtime.device_manager.registry import DeviceRegistry
from openpendant.runtime.interfaces.camera import Encoding
from openpendant.runtime.kit.errors import Conflict, OpenPendantError, Unavailable
from openpendant.runtime.kit.websocket import send_error, until_either_ends


async def relay_frames(
    ws: WebSocket, registry: DeviceRegistry, local_name: str, encoding: Encoding, quality: int
) -> None:
    await ws.accept()
    try:
        conn = registry.connection(local_name)
        if not declares(conn.record.kind, "frames"):
            raise Conflict(f"{local_name} is a {conn.record.kind}, not a camera", code="not_camera")
        query = urlencode({"encoding": encoding, "quality": min(max(quality, 1), 100)})
        try:
            upstream = await conn.open_stream("/frames/ws", query)
        except (OSError, websockets.WebSocketException, TimeoutError) as exc:
            raise Unavailable(
                f"{local_name} does not stream frames: {type(exc).__name__}",
                code="device_disconnected",
            ) from exc
    except OpenPendantError as exc:
        await send_error(ws, exc)
        await ws.close(code=1011)
        return

    async def down() -> None:
        async for message in upstream:
            if isinstance(message, str):
                await ws.send_text(message)
            else:
                await ws.send_bytes(message)

    async def up() -> None:
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            # Any message is "drawn": the viewer wants the next frame.
            await upstream.send(json.dumps({"ack": True}))

    async with upstream:
        await until_either_ends(ws, down(), up(), expected=(websockets.WebSocketException,))
