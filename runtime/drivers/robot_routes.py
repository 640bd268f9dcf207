"""HTTP and WebSocket routes of the standard robot interface, for any RobotDriver."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response, WebSocket
from pydantic import ValidationError

from runtime.drivers.state_stream import StateStream
from runtime.interfaces.robot import (
    CommandModeRequest,
    JogJointCommand,
    JointTrajectory,
    PositionCommand,
    RobotDescription,
    RobotState,
    SpeedRatioRequest,
    TrajectoryAccepted,
    TrajectoryStatus,
    VelocityCommand,
)
from runtime.interfaces.robot_driver import RobotDriver
from runtime.kit.app import describe_validation_errors
from runtime.kit.errors import OpenPendantError
from runtime.kit.websocket import Fanout


def robot_router(driver: RobotDriver, stream: StateStream) -> APIRouter:
    router = APIRouter()

    @router.get("/info")
    async def info() -> RobotDescription:
        return driver.describe()

    @router.get("/state")
    async def state() -> RobotState:
        return driver.state()

    @router.websocket("/state/ws")
    async def state_ws(ws: WebSocket, max_rate: float | None = None) -> None:
        await stream.fanout.serve(ws, max_rate_hz=max_rate)

    @router.post("/enable")
    async def enable() -> RobotState:
        await driver.enable()
        return driver.state()

    @router.post("/disable")
    async def disable() -> RobotState:
        await driver.disable()
        return driver.state()

    @router.post("/reset_errors")
    async def reset_errors() -> RobotState:
        await driver.reset_errors()
        return driver.state()

    @router.post("/halt")
    async def halt() -> RobotState:
        await driver.halt()
        return driver.state()

    @router.put("/command_mode")
    async def command_mode(body: CommandModeRequest) -> RobotState:
        await driver.set_command_mode(body.mode)
        return driver.state()

    @router.put("/speed_ratio")
    async def speed_ratio(body: SpeedRatioRequest) -> RobotState:
        await driver.set_speed_ratio(body.ratio)
        return driver.state()

    @router.post("/jog_joint", status_code=204)
    async def jog_joint(body: JogJointCommand) -> Response:
        await driver.jog_joint(body)
        return Response(status_code=204)

    @router.post("/velocity_command", status_code=204)
    async def velocity_command(body: VelocityCommand) -> Response:
        await driver.velocity_command(body)
        return Response(status_code=204)

    @router.post("/position_command", status_code=204)
    async def position_command(body: PositionCommand) -> Response:
        await driver.position_command(body)
        return Response(status_code=204)

    @router.post("/trajectory")
    async def trajectory(body: JointTrajectory) -> TrajectoryAccepted:
        return await driver.execute_trajectory(body)

    @router.get("/trajectory/{trajectory_id}")
    async def trajectory_status(trajectory_id: str) -> TrajectoryStatus:
        return await driver.trajectory_status(trajectory_id)

    @router.websocket("/command/ws")
    async def command_ws(ws: WebSocket) -> None:
        """Streamed commands, one JSON object per message with a `type`; errors come back."""

        commanded = False

        async def handle(message: Any) -> None:
            nonlocal commanded
            await dispatch_stream_command(driver, message)
            commanded = True

        try:
            await Fanout().serve(ws, on_message=handle)
        finally:
            # A stream that drops must not leave the robot coasting until its timeout.
            if commanded:
                await driver.halt()

    return router


async def dispatch_stream_command(driver: RobotDriver, message: Any) -> None:
    if not isinstance(message, dict):
        raise OpenPendantError("a command must be a JSON object", code="bad_message")
    kind = message.get("type")
    fields = {k: v for k, v in message.items() if k != "type"}
    try:
        if kind == "jog_joint":
            await driver.jog_joint(JogJointCommand.model_validate(fields))
        elif kind == "velocity_command":
            await driver.velocity_command(VelocityCommand.model_validate(fields))
        elif kind == "position_command":
            await driver.position_command(PositionCommand.model_validate(fields))
        elif kind == "halt":
            await driver.halt()
        else:
            raise OpenPendantError(f"unknown command type {kind!r}", code="bad_message")
    except ValidationError as exc:
        text, _ = describe_validation_errors(exc.errors())
        raise OpenPendantError(text, code="invalid_request", status=422) from exc
