"""The jog service: /jog/ws for hold-to-run jogging and moves, REST for teaching waypoints,
robot power commands and what the jog panel needs to know about a robot."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import APIRouter, FastAPI, Header, WebSocket

from openpendant.runtime.cell.mirror import WorldMirror
from openpendant.runtime.clients.devices import Devices
from openpendant.runtime.interfaces.robot import RobotState, SpeedRatioRequest
from openpendant.runtime.interfaces.variables import Variable
from openpendant.runtime.jog.clearance import PathCheck
from openpendant.runtime.jog.directory import Directory
from openpendant.runtime.jog.models import (
    Avoidance,
    Halted,
    JogSettings,
    RobotModel,
    SpeedRequest,
    SpeedSet,
    TeachRequest,
    Waypoint,
)
from openpendant.runtime.jog.session import ANGULAR_SPEED, JOINT_SPEED, LINEAR_SPEED, JogSession
from openpendant.runtime.jog.waypoints import robot_waypoints, teach
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.motion.client import MotionClient
from openpendant.runtime.paths import package_roots
from openpendant.runtime.robotics.velocity import MANUAL_TCP_SPEED
from openpendant.runtime.variable_storage.client import StorageClient

LeaseToken = Annotated[str | None, Header(alias="X-Lease-Token", max_length=64)]


def jog_router(
    directory: Directory,
    storage: StorageClient,
    paths: PathCheck,
    site: RuntimeSettings,
) -> APIRouter:
    deadman = site.deadman_seconds
    socket_port = site.jog_port or None
    router = APIRouter(prefix="/jog")

    @router.get("/settings")
    async def settings() -> JogSettings:
        return JogSettings(
            socket_port=socket_port,
            deadman_ms=round(deadman * 1000),
            joint_speed=JOINT_SPEED,
            linear_speed=LINEAR_SPEED,
            angular_speed=ANGULAR_SPEED,
            manual_tcp_speed=MANUAL_TCP_SPEED,
            heartbeat_ms=max(10, min(50, round(deadman * 1000 / 4))),
            first_speed_ratio=site.link.first_speed_ratio,
        )

    @router.websocket("/ws")
    async def jog_socket(ws: WebSocket) -> None:
        session = JogSession(directory, storage, deadman, paths, site.motion)
        try:
            await session.out.serve(ws, on_message=session.handle)
        finally:
            await session.close()

    @router.get("/robots/{robot}")
    async def robot(robot: str) -> RobotModel:
        jogger = await directory.jogger(robot)
        info = jogger.link.info
        return RobotModel(
            name=robot,
            info=info,
            urdf=_public_uri(info.urdf),
            packages={name: f"/api/robot-files/{name}" for name in package_roots()},
        )

    @router.post("/robots/{robot}/teach", status_code=201)
    async def teach_waypoint(robot: str, body: TeachRequest) -> Variable:
        jogger = await directory.jogger(robot)
        return await teach(storage, robot, jogger.link.current(), jogger.kinematics, body)

    @router.get("/robots/{robot}/waypoints")
    async def waypoints(robot: str) -> list[Waypoint]:
        jogger = await directory.jogger(robot)
        return await robot_waypoints(storage, robot, jogger.kinematics)

    @router.post("/robots/{robot}/halt")
    async def halt(robot: str) -> Halted:
        """Stop always wins: any client may halt any robot, lease or not."""
        await directory.halt(robot, "stop requested")
        jogger = directory.joggers.get(robot)
        state = jogger.link.latest() if jogger is not None else None
        return Halted(robot=robot, halted=True, state=state)

    @router.put("/robots/{robot}/speed")
    async def speed(robot: str, body: SpeedRequest, token: LeaseToken = None) -> SpeedSet:
        """The speed override: a running program's moves slow down or speed up along their
        paths. Anyone may lower it (slowing is always safe); raising it needs control."""
        jogger = await directory.jogger(robot)
        if body.ratio > jogger.link.current().speed_ratio + 1e-9:
            await directory.check_lease(robot, token)
        state = await jogger.link.set_speed_ratio(SpeedRatioRequest(ratio=body.ratio))
        return SpeedSet(robot=robot, speed_ratio=state.speed_ratio)

    @router.post("/robots/{robot}/enable")
    async def enable(robot: str, token: LeaseToken = None) -> RobotState:
        await directory.check_lease(robot, token)
        return await (await directory.jogger(robot)).link.enable()

    @router.post("/robots/{robot}/disable")
    async def disable(robot: str, token: LeaseToken = None) -> RobotState:
        await directory.check_lease(robot, token)
        return await (await directory.jogger(robot)).link.disable()

    @router.post("/robots/{robot}/reset_errors")
    async def reset_errors(robot: str, token: LeaseToken = None) -> RobotState:
        await directory.check_lease(robot, token)
        return await (await directory.jogger(robot)).link.reset_errors()

    return router


def avoidance_router(mirror: WorldMirror) -> APIRouter:
    router = APIRouter(prefix="/jog")

    @router.get("/avoidance")
    async def avoidance() -> Avoidance:
        return Avoidance(
            ready=mirror.refreshed.is_set(),
            robots=sorted(mirror.world.robots),
            objects=sorted(mirror.world.objects),
        )

    return router


def _public_uri(urdf: str) -> str | None:
    if urdf.startswith("package://"):
        return "/api/robot-files/" + urdf.removeprefix("package://")
    return None


def build_app(settings: RuntimeSettings, urls: dict[str, str]) -> FastAPI:
    storage = StorageClient(urls["variable_storage"])
    motion = MotionClient(urls["motion"])
    devices = Devices(urls["device_manager"], "jog", settings.link.stale_after)
    mirror = WorldMirror(devices, storage)
    directory = Directory(devices, avoidance=mirror.constraint)

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        await devices.start()
        await mirror.start()
        try:
            yield
        finally:
            await directory.close()
            await mirror.close()
            await devices.close()
            await motion.aclose()
            await storage.aclose()

    app = create_app("jog", lifespan=lifespan)
    paths = PathCheck(motion)
    app.include_router(jog_router(directory, storage, paths, settings))
    app.include_router(avoidance_router(mirror))
    return app
