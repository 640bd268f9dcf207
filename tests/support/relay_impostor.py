"""The impostor of issue 31, for the link tests: from a host of its own it announces an added
robot's uuid and TXT and passes on to the real robot whatever it is asked to read, the
pairing challenge included, giving the answers back as its own (the real robot's states too).
What it is told to do it keeps to itself: commands on its command socket and changing
requests are recorded, never passed on.

`python -m tests.support.relay_impostor HOST UPSTREAM_URL` serves and announces on HOST
(discovery on that address only), prints `{"event": "ready", "url": …, "uuid": …}` once
announced, and says goodbye on SIGTERM. `GET /impostor/commands`: what it was told."""

from __future__ import annotations

import asyncio
import contextlib
import json
import sys
from collections.abc import AsyncIterator
from typing import Any

import httpx
import uvicorn
import websockets
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from openpendant.runtime.kit.discovery import Advertisement, Advertiser
from openpendant.runtime.kit.serve import listening_socket


def build(host: str, upstream: str, port: int, identity: dict[str, Any]) -> Starlette:
    told: list[dict[str, Any]] = []
    http = httpx.AsyncClient(base_url=upstream, timeout=5.0)

    async def passed_on(request: Request) -> Response:
        answer = await http.get(request.url.path, params=request.query_params)
        return Response(answer.content, answer.status_code, media_type="application/json")

    async def kept(request: Request) -> Response:
        told.append({"type": request.url.path.strip("/"), "method": request.method})
        return Response(status_code=204)

    async def commands(_: Request) -> JSONResponse:
        return JSONResponse(told)

    async def states(ws: WebSocket) -> None:
        await ws.accept()
        ws_url = upstream.replace("http://", "ws://", 1) + "/state/ws"
        with contextlib.suppress(WebSocketDisconnect, websockets.WebSocketException, OSError):
            async with websockets.connect(ws_url, compression=None) as real:
                async for message in real:
                    await ws.send_text(message if isinstance(message, str) else message.decode())

    async def command_socket(ws: WebSocket) -> None:
        await ws.accept()  # no signature asked: it obeys no one, it listens to anyone
        with contextlib.suppress(WebSocketDisconnect, RuntimeError):
            while True:
                message = json.loads(await ws.receive_text())
                if message.get("type") not in ("session", "keepalive"):
                    told.append(message)

    @contextlib.asynccontextmanager
    async def lifespan(_: Starlette) -> AsyncIterator[None]:
        advertiser = Advertiser([host])
        ad = Advertisement(
            uuid=str(identity["uuid"]),
            kind=str(identity["kind"]),
            model=str(identity["model"]),
            name=str(identity["name"]),
            host=host,
            port=port,
            key="",  # it holds no key: it passes the device's proofs on
        )
        await advertiser.start(ad)
        ready = {"event": "ready", "url": f"http://{host}:{port}", "uuid": ad.uuid}
        print(json.dumps(ready), flush=True)
        try:
            yield
        finally:
            await advertiser.stop()
            await http.aclose()

    reads = ("/info", "/state", "/pair/proof", "/command_log", "/clients")
    return Starlette(
        routes=[
            *(Route(path, passed_on) for path in reads),
            Route("/impostor/commands", commands),
            WebSocketRoute("/state/ws", states),
            WebSocketRoute("/command/ws", command_socket),
            Route("/{path:path}", kept, methods=["POST", "PUT", "DELETE"]),
        ],
        lifespan=lifespan,
    )


def main(host: str, upstream: str) -> None:
    identity = httpx.get(f"{upstream}/info", timeout=5.0).json()["identity"]
    sock = listening_socket(host, 0)
    app = build(host, upstream, int(sock.getsockname()[1]), identity)
    config = uvicorn.Config(app, log_config=None, access_log=False, lifespan="on")
    asyncio.run(uvicorn.Server(config).serve(sockets=[sock]))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
