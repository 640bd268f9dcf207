"""Serve one device driver: its routes, its state stream and its DNS-SD advertisement."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import socket
import sys
from collections.abc import AsyncIterator, Sequence
from typing import Any

from fastapi import APIRouter, FastAPI, Query, WebSocket

from openpendant.plugins.api import resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.drivers import command_stream
from openpendant.runtime.drivers.command_log import CommandLog
from openpendant.runtime.drivers.guard import CommandGuard
from openpendant.runtime.drivers.routes import interface_router
from openpendant.runtime.drivers.state_stream import StateStream
from openpendant.runtime.interfaces.device import DeviceDriver
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.device_auth import key_id
from openpendant.runtime.kit.discovery import DEFAULT_TTL, Advertisement, Advertiser, Interfaces
from openpendant.runtime.kit.serve import listening_socket, run_app
from openpendant.runtime.kit.tasks import cancel_for_sure

log = logging.getLogger(__name__)


def advertised_host(host: str) -> str:
    if host in ("0.0.0.0", ""):
        # Bound everywhere: advertise the address the OS would use to reach the LAN.
        with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_DGRAM)) as probe:
            try:
                probe.connect(("192.0.2.1", 9))  # no packet is sent for a UDP connect
                return str(probe.getsockname()[0])
            except OSError:
                return "127.0.0.1"
    return host


def device_router(driver: DeviceDriver, stream: StateStream) -> APIRouter:
    """What every driver serves, whatever its kind."""
    router = APIRouter()

    @router.get("/info")
    async def info() -> Any:
        return driver.describe()

    @router.get("/state")
    async def state() -> Any:
        return driver.state()

    @router.get("/clients")
    async def clients() -> dict[str, int]:
        """Who is connected: state streams, command streams and runtime sessions."""
        return {
            "state_streams": len(stream.fanout.subscribers),
            "command_streams": len(command_stream.OPEN),
            "sessions": sum(1 for c in command_stream.OPEN if c.session_timeout is not None),
        }

    @router.websocket("/state/ws")
    async def state_ws(ws: WebSocket, max_rate: float | None = Query(None, gt=0, le=1000)) -> None:
        await stream.fanout.serve(ws, [stream.current()], max_rate_hz=max_rate)

    return router


def build_driver_app(
    driver: DeviceDriver,
    *,
    advertisement: Advertisement | None,
    interfaces: Interfaces,
    state_rate_hz: float,
    routers: Sequence[APIRouter] = (),
) -> FastAPI:
    stream = StateStream(driver.state, state_rate_hz, driver.state_changed)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await driver.start()
        pusher = asyncio.create_task(stream.run())
        advertiser = Advertiser(interfaces)
        if advertisement is not None:
            await advertiser.start(advertisement)
            # One machine-readable line so a parent process or a test knows where we are.
            print(
                json.dumps(
                    {
                        "event": "ready",
                        "url": f"http://{advertisement.host}:{advertisement.port}",
                        "uuid": advertisement.uuid,
                    }
                ),
                flush=True,
            )
        try:
            yield
        finally:
            await advertiser.stop()
            await cancel_for_sure(pusher)
            await driver.shutdown()

    name = f"{driver.kind}-driver:{driver.identity.name}"
    # No /metrics on a device's port: it answers anyone on the network.
    app = create_app(name, lifespan=lifespan, metrics_route=False)
    log = CommandLog()
    app.include_router(device_router(driver, stream))
    app.include_router(interface_router(driver, log))
    for router in (*kind_routers(driver, log), *routers):
        app.include_router(router)
    return app


def kind_routers(driver: DeviceDriver, log: CommandLog) -> list[APIRouter]:
    """The routes of the driver's kind that its declarations cannot say (a robot's command
    socket, a camera's frame stream)."""
    kind = registry().kinds.get(driver.kind)
    if kind is None:
        raise ValueError(f"no installed plugin declares devices of kind {driver.kind!r}")
    return [resolve(kind.routes)(driver, log)] if kind.routes else []


def serve_driver(
    driver: DeviceDriver,
    *,
    host: str,
    port: int,
    interfaces: Interfaces,
    state_rate_hz: float,
    routers: Sequence[APIRouter] = (),
    ttl: int = DEFAULT_TTL,
    secret: str,
    runtime: str = "",
) -> None:
    """`runtime`: the tag of the runtime that started the device (announced), if one did."""
    sock = listening_socket(host, port)
    actual_port = int(sock.getsockname()[1])
    ident = driver.identity
    advertisement = Advertisement(
        uuid=ident.uuid,
        kind=ident.kind,
        model=ident.model,
        name=ident.name,
        host=advertised_host(host),
        port=actual_port,
        key=key_id(secret),
        runtime=runtime,
        ttl=ttl,
    )
    app = build_driver_app(
        driver,
        advertisement=advertisement,
        interfaces=interfaces,
        state_rate_hz=state_rate_hz,
        routers=routers,
    )
    log.info("serving %s on port %d", ident.name, actual_port)
    sys.stdout.flush()
    run_app(CommandGuard(app, secret), sock)
