"""What the runtime's ASGI guards share: reading a request's headers, and refusing a request
or a socket with the runtime's error body before the app sees it."""

from __future__ import annotations

import json

from starlette.types import Receive, Scope, Send


def headers_of(scope: Scope) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}


def header(scope: Scope, name: str) -> str | None:
    wanted = name.lower().encode()
    for key, value in scope.get("headers", []):
        if key.lower() == wanted:
            return bytes(value).decode("latin-1")
    return None


async def send_error(send: Send, status: int, code: str, message: str) -> None:
    """An HTTP answer {"error": {"code", "message"}} sent straight on the ASGI channel."""
    payload = json.dumps({"error": {"code": code, "message": message}}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(payload)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": payload})


async def refuse(
    scope: Scope, receive: Receive, send: Send, status: int, code: str, message: str
) -> None:
    if scope["type"] == "websocket":
        # Closed before it is accepted: nothing the socket would have carried is acted on.
        await send({"type": "websocket.close", "code": 1008, "reason": code})
        return
    await send_error(send, status, code, message)
