"""HTTP and WebSocket routes of the standard robot interface, for any RobotDriver."""

from __future__ import annotations

from fastapi import APIRouter, Response, WebSocket

from runtime.drivers.command_log import CommandLog, LoggedCommand
from runtime.drivers.command_stream import CommandStream
from runtime.interfaces.robot import (
    CommandModeRequest,
    DigitalOutputCommand,
    JogJointCommand,
    JointTrajectory,
    PositionCommand,
    RobotDescription,
    RobotState,
    SpeedRatioRequest,
    ToolCommand,
    ToolSetup,
    TrajectoryAccepted,
    TrajectoryStatus,
    VelocityCommand,
)
from runtime.interfaces.robot_driver import RobotDriver


def robot_router(driver: RobotDriver, log: CommandLog) -> APIRouter:
    """The robot's commands (GET /info, /state and /state/ws are the host's)."""
    router = APIRouter()

    @router.get("/command_log")
    async def command_log(after: int = 0) -> list[LoggedCommand]:
        """Commands this driver accepted, newest last (the last 2000)."""
        return log.since(after)

    @router.post("/enable")
    async def enable() -> RobotState:
        await driver.enable()
        log.record("enable")
        return driver.state()

    @router.post("/disable")
    async def disable() -> RobotState:
        await driver.disable()
        log.record("disable")
        return driver.state()

    @router.post("/reset_errors")
    async def reset_errors() -> RobotState:
        await driver.reset_errors()
        log.record("reset_errors")
        return driver.state()

    @router.post("/halt")
    async def halt() -> RobotState:
        await driver.halt()
        log.record("halt")
        return driver.state()

    @router.put("/command_mode")
    async def command_mode(body: CommandModeRequest) -> RobotState:
        await driver.set_command_mode(body.mode)
        log.record(f"command_mode:{body.mode.value}")
        return driver.state()

    @router.put("/speed_ratio")
    async def speed_ratio(body: SpeedRatioRequest) -> RobotState:
        await driver.set_speed_ratio(body.ratio)
        log.record("speed_ratio")
        return driver.state()

    @router.put("/tool_setup")
    async def tool_setup(body: ToolSetup) -> RobotDescription:
        """The mounted tool's TCP and payload; the robot halts first. Answers the new info."""
        await driver.set_tool_setup(body)
        log.record("tool_setup")
        return driver.describe()

    @router.post("/tool")
    async def tool(body: ToolCommand) -> RobotState:
        await driver.set_tool(body.open)
        log.record("tool:open" if body.open else "tool:close")
        return driver.state()

    @router.put("/digital_outputs/{index}")
    async def digital_output(index: int, body: DigitalOutputCommand) -> RobotState:
        await driver.set_digital_output(index, body.value)
        log.record(f"digital_output:{index}:{int(body.value)}")
        return driver.state()

    @router.post("/jog_joint", status_code=204)
    async def jog_joint(body: JogJointCommand) -> Response:
        await driver.jog_joint(body)
        log.record("jog_joint", body.tag)
        return Response(status_code=204)

    @router.post("/velocity_command", status_code=204)
    async def velocity_command(body: VelocityCommand) -> Response:
        await driver.velocity_command(body)
        log.record("velocity_command", body.tag)
        return Response(status_code=204)

    @router.post("/position_command", status_code=204)
    async def position_command(body: PositionCommand) -> Response:
        await driver.position_command(body)
        log.record("position_command", body.tag)
        return Response(status_code=204)

    @router.post("/trajectory")
    async def trajectory(body: JointTrajectory) -> TrajectoryAccepted:
        accepted = await driver.execute_trajectory(body)
        log.record("trajectory", accepted.id)
        return accepted

    @router.post("/trajectory/pause")
    async def pause_trajectory() -> TrajectoryStatus:
        """A controlled stop along the running trajectory's path; resumable."""
        status = await driver.pause_trajectory()
        log.record("trajectory:pause", status.id)
        return status

    @router.post("/trajectory/resume")
    async def resume_trajectory() -> TrajectoryStatus:
        status = await driver.resume_trajectory()
        log.record("trajectory:resume", status.id)
        return status

    @router.get("/trajectory/{trajectory_id}")
    async def trajectory_status(trajectory_id: str) -> TrajectoryStatus:
        return await driver.trajectory_status(trajectory_id)

    @router.websocket("/command/ws")
    async def command_ws(ws: WebSocket) -> None:
        """Streamed commands, one JSON object per message with a `type` (jog_joint,
        velocity_command, position_command, command_mode, halt; session, keepalive); they
        apply in order, and refusals come back on the socket (with the command's `id`)."""
        await CommandStream(driver, log).serve(ws)

    return router
