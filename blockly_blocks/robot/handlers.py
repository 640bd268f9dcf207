"""The runtime's answers to the robot blocks' calls (runtime/program/calls.py says how
they are written)."""

from __future__ import annotations

from typing import Any, cast

from openpendant.runtime.interfaces.robot import RobotState, ToolCommand
from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.motion.client import MoveKind, MoveRequest, Target
from openpendant.runtime.program.calls import checked
from openpendant.runtime.program.host import RunHost
from openpendant.sandbox.supervisor import CallRefused


async def use_robot(run: RunHost, args: dict[str, Any]) -> None:
    name = str(args["robot"])
    try:
        details = await run.devices.manager.device(name)
    except NotFound:
        raise CallRefused(f"there is no robot {name!r}", "unknown_device") from None
    if details.kind != "robot":
        raise CallRefused(f"{name} is a {details.kind}, not a robot", "not_a_robot")
    run.robot = name


async def move(run: RunHost, args: dict[str, Any]) -> None:
    kind = args["kind"]
    if kind not in ("joint", "linear"):
        raise CallRefused(f"unknown move kind {kind!r}", "bad_call")
    target = checked(Target, args["target"])
    await run.run_move(MoveRequest(kind=MoveKind(kind), target=target))


async def move_relative(run: RunHost, args: dict[str, Any]) -> None:
    request = {"kind": "relative", "offset": args["offset"], "offset_frame": args["frame"]}
    await run.run_move(checked(MoveRequest, request))


async def move_home(run: RunHost, _: dict[str, Any]) -> None:
    robot = await run.active_robot()
    details = await run.devices.manager.device(robot)
    home = (details.info or {})["info"]["home"]
    await run.run_move(MoveRequest(kind=MoveKind.joint, target=Target(joints=home)))


async def set_speed(run: RunHost, args: dict[str, Any]) -> None:
    ratio = float(args["ratio"])
    if not 0 < ratio <= 1:
        raise CallRefused("speed must be between 1 and 100 %", "invalid_value")
    run.speed = ratio


async def _state(run: RunHost) -> RobotState:
    """The active robot's newest state from this service's own link to it (watched from
    the first read on), not asked of the device manager on each call; a state that is not
    fresh is refused with the reason."""
    robot = await run.active_robot()
    client = await run.read_device(robot, "robot")
    return cast(RobotState, client.current())


async def joint_positions(run: RunHost, _: dict[str, Any]) -> list[float]:
    return [float(v) for v in (await _state(run)).joint_position]


async def tcp_pose(run: RunHost, _: dict[str, Any]) -> Any:
    return (await _state(run)).tcp_pose.model_dump(mode="json")


async def tool(run: RunHost, args: dict[str, Any]) -> None:
    robot = await run.active_robot()
    client = await run.robot_client(robot)
    await client.set_tool(ToolCommand(open=bool(args["open"])))
