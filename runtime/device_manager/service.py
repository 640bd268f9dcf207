"""Device manager routes: /devices/…"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import Annotated, Any

from fastapi import APIRouter, FastAPI, Header, Response, WebSocket
from fastapi.responses import JSONResponse
from prometheus_client import REGISTRY

from openpendant.runtime.device_manager.calls import CallRequest, call_device, stop_all
from openpendant.runtime.device_manager.cell import cell_parts
from openpendant.runtime.device_manager.frames import relay_frames
from openpendant.runtime.device_manager.metrics import LinkCollector
from openpendant.runtime.device_manager.models import (
    AddDeviceRequest,
    AddedDevice,
    CellPart,
    DetectedDevice,
    DeviceDetails,
    LeaseGranted,
    LeaseInfo,
    LeaseRequest,
    RepointRequest,
)
from openpendant.runtime.device_manager.registry import DeviceRegistry
from openpendant.runtime.interfaces.camera import Encoding
from openpendant.runtime.interfaces.robot import RobotInfo, ToolSetup
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.discovery import Browser
from openpendant.runtime.kit.errors import Unavailable
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.kit.websocket import Fanout
from openpendant.runtime.variable_storage.client import StorageClient

LeaseToken = Annotated[str | None, Header(alias="X-Lease-Token", max_length=64)]


def devices_router(registry: DeviceRegistry) -> APIRouter:
    router = APIRouter(prefix="/devices")

    @router.get("/detected")
    async def detected() -> list[DetectedDevice]:
        return registry.detected_list()

    @router.websocket("/ws")
    async def live(
        ws: WebSocket, max_rate: float | None = None, states: bool = True, batch: bool = False
    ) -> None:
        """Detected list, added devices with status, and (unless states=false) every
        device's state, pushed. `batch`: frames of all that changed, each acknowledged by
        the client (`{"type": "ack"}`) before more come (the UI: once per drawn frame)."""
        fanout = registry.fanout if states else registry.events
        await fanout.serve(
            ws, registry.snapshot_messages(states), max_rate_hz=max_rate, acked=batch
        )

    @router.websocket("/{local_name}/frames/ws")
    async def frames(
        ws: WebSocket, local_name: str, encoding: Encoding = "jpeg", quality: int = 80
    ) -> None:
        """A camera's live frames, each a JSON text message (when it was taken, its size)
        then the image; the next comes after the viewer sends any text (it drew this one)."""
        await relay_frames(ws, registry, local_name, encoding, quality)

    @router.websocket("/_links")
    async def links(ws: WebSocket) -> None:
        """For services: the one link per device (runtime/device_manager/links.py)."""
        await registry.links.serve(ws)

    @router.get("")
    async def added() -> list[AddedDevice]:
        return registry.added_list()

    @router.post("", status_code=201)
    async def add(body: AddDeviceRequest) -> AddedDevice:
        return await registry.add(body)

    @router.get("/{local_name}")
    async def details(local_name: str) -> DeviceDetails:
        return registry.details(local_name)

    @router.put("/{local_name}/address")
    async def repoint(local_name: str, body: RepointRequest) -> AddedDevice:
        """Point an added device at another address (its robot is halted first)."""
        return await registry.repoint(local_name, body.url)

    @router.delete("/{local_name}")
    async def remove(local_name: str) -> AddedDevice:
        return await registry.remove(local_name)

    @router.get("/{local_name}/lease")
    async def lease(local_name: str) -> LeaseInfo:
        return registry.lease_info(local_name)

    @router.post("/{local_name}/lease")
    async def take_lease(
        local_name: str, body: LeaseRequest, token: LeaseToken = None
    ) -> LeaseGranted:
        """Take control (or, with your token, renew it)."""
        return registry.acquire_lease(local_name, body.holder, token)

    @router.post("/{local_name}/lease/check")
    async def check_lease(local_name: str, token: LeaseToken = None) -> LeaseGranted:
        """For services: is this token in control? A valid check renews the lease."""
        return registry.check_lease(local_name, token)

    @router.delete("/{local_name}/lease", status_code=204)
    async def release_lease(local_name: str, token: LeaseToken = None) -> Response:
        registry.release_lease(local_name, token)
        return Response(status_code=204)

    @router.put("/{local_name}/tool")
    async def set_tool(local_name: str, body: ToolSetup, token: LeaseToken = None) -> RobotInfo:
        """The robot's TCP and payload (needs control; the robot halts). Stored as
        `tools.<robot>` and applied again whenever the robot connects."""
        return await registry.set_tool(local_name, body, token)

    @router.post("/_stop")
    async def stop_devices() -> dict[str, list[str]]:
        """STOP for every device that is not a robot (grippers, a plugin's devices…): anyone may."""
        return {"stopped": await stop_all(registry)}

    @router.post("/{local_name}/call/{method}")
    async def call(
        local_name: str, method: str, body: CallRequest, token: LeaseToken = None
    ) -> Response:
        """Call a method the device's kind declares (a command needs control)."""
        status, content = await call_device(registry, local_name, method, body, token)
        return JSONResponse(content, status_code=status)

    @router.get("/{local_name}/cell/parts")
    async def parts(local_name: str) -> list[CellPart]:
        """A simulated cell's parts, where they truly are (the 3D view draws them)."""
        return await cell_parts(registry, local_name)

    @router.get("/{local_name}/state")
    async def state(local_name: str) -> Response:
        return Response(registry.state_text(local_name), media_type="application/json")

    return router


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    storage = StorageClient(urls["variable_storage"])
    registry = DeviceRegistry(
        storage,
        Fanout(),
        settings.lease_seconds,
        settings.link,
        lease_file=settings.data_dir / "leases.json",
        data_dir=settings.data_dir,
    )
    browser = Browser(
        settings.zeroconf_interfaces(), registry.on_found, registry.on_gone, registry.vouches_for
    )

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        links = LinkCollector(registry)
        REGISTRY.register(links)
        await browser.start()
        loader = asyncio.create_task(registry.load())
        sweeper = asyncio.create_task(registry.sweep_leases())
        try:
            yield
        finally:
            loader.cancel()
            sweeper.cancel()
            await browser.stop()
            await registry.close()
            await storage.aclose()
            REGISTRY.unregister(links)

    async def health() -> dict[str, Any]:
        if not registry.loaded:
            raise Unavailable(
                "loading the added devices from the variable storage", code="starting"
            )
        return {"devices": len(registry.connections), "detected": len(registry.detected)}

    app = create_app("device_manager", lifespan=lifespan, health=health)
    app.include_router(devices_router(registry))
    return app
