"""The runtime's answers to the built-in blocks' sandbox calls (declared with the blocks in
`blockly_blocks/plugin.py`). Each is `async def handler(run, args)`: `run` is the run's
RunHost, `args` what the sandbox function sent, checked here again."""

from __future__ import annotations

import re
from typing import Any, TypeVar, cast

from pydantic import BaseModel, ValidationError

from openpendant.runtime.clients.kinds import IOClient
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.interfaces.robot import DigitalOutputCommand, ToolCommand
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.kit.words import words
from openpendant.runtime.motion.client import MoveKind, MoveRequest, Target
from openpendant.runtime.program.host import RunHost
from openpendant.runtime.program.stored_values import checked_name, put_value
from openpendant.sandbox.supervisor import CallRefused

M = TypeVar("M", bound=BaseModel)
IO_NAME = re.compile(r"^([a-z][a-z0-9_]{0,31})\.(di|do)(\d{1,2})\Z")  # a robot's
DEVICE_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")
SIGNAL = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")
WAYPOINT_TYPES = ("joint_waypoint", "pose_waypoint")


def _checked(model: type[M], value: Any) -> M:
    """A value from the sandbox as a model, or the reason it is not one."""
    try:
        return model.model_validate(value)
    except ValidationError as exc:
        message, _ = describe_validation_errors(exc.errors())
        raise CallRefused(message, "invalid_request") from None


# Robot ------------------------------------------------------------------------------------


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
    target = _checked(Target, args["target"])
    await run.run_move(MoveRequest(kind=MoveKind(kind), target=target))


async def move_relative(run: RunHost, args: dict[str, Any]) -> None:
    request = {"kind": "relative", "offset": args["offset"], "offset_frame": args["frame"]}
    await run.run_move(_checked(MoveRequest, request))


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


async def _state(run: RunHost) -> dict[str, Any]:
    robot = await run.active_robot()
    state = await run.devices.manager.state(robot)
    if not state:
        raise CallRefused(f"no state from {robot}", "device_disconnected")
    return state


async def joint_positions(run: RunHost, _: dict[str, Any]) -> list[float]:
    return [float(v) for v in (await _state(run))["joint_position"]]


async def tcp_pose(run: RunHost, _: dict[str, Any]) -> Any:
    return (await _state(run))["tcp_pose"]


async def tool(run: RunHost, args: dict[str, Any]) -> None:
    robot = await run.active_robot()
    client = await run.robot_client(robot)
    await client.set_tool(ToolCommand(open=bool(args["open"])))


# Waypoints, I/O, stored values ------------------------------------------------------------


async def check_waypoint(run: RunHost, args: dict[str, Any]) -> dict[str, str]:
    name = str(args["name"])
    try:
        variable = await run.storage.get(name)
    except NotFound:
        raise CallRefused(
            f"there is no waypoint {name!r}",
            "unknown_waypoint",
            words("run.no_waypoint", name=name),
        ) from None
    if variable.type not in WAYPOINT_TYPES:
        raise CallRefused(f"{name} is a {variable.type}, not a waypoint", "not_a_waypoint")
    return {"type": variable.type}


async def signal_of(run: RunHost, name: str) -> tuple[str, str, str]:
    """(device, its kind, signal) of "<device>.<signal>": a robot controller's do0/di3, or
    a signal an I/O block's register map names (cell_io.lamp_green)."""
    device, dot, signal = name.partition(".")
    if not dot or not DEVICE_NAME.match(device) or not SIGNAL.match(signal):
        raise CallRefused(
            f"I/O names look like robot.do0 or cell_io.lamp, not {name[:40]!r}", "unknown_io"
        )
    kind = run.kinds.get(device)
    if kind is None:
        try:
            kind = run.kinds[device] = (await run.devices.manager.device(device)).kind
        except NotFound:
            raise CallRefused(f"there is no device {device!r}", "unknown_device") from None
    if kind == "robot" and IO_NAME.match(name) is None:
        raise CallRefused(f"a robot's I/O is do0, do1, … di0, di1, …, not {signal!r}", "unknown_io")
    if kind not in ("robot", "io"):
        raise CallRefused(f"{device} is a {kind}: it has no inputs or outputs", "unknown_io")
    return device, kind, signal


async def set_output(run: RunHost, args: dict[str, Any]) -> None:
    name = str(args["name"])
    device, kind, signal = await signal_of(run, name)
    value = bool(args["value"])
    if kind == "io":
        block = cast(IOClient, await run.device(device, "io"))
        try:
            await block.write(signal, SignalWrite(value=value))
        except (NotFound, InvalidValue) as exc:
            raise CallRefused(f"{device}: {exc.message}", exc.code) from None
        return
    if not signal.startswith("do"):
        raise CallRefused(f"{name} is an input; only outputs can be set", "read_only")
    client = await run.robot_client(device)
    await client.set_digital_output(int(signal[2:]), DigitalOutputCommand(value=value))


async def get_io(run: RunHost, args: dict[str, Any]) -> bool:
    name = str(args["name"])
    device, kind, signal = await signal_of(run, name)
    if kind == "io":
        block = cast(IOClient, await run.read_device(device, "io"))
        try:
            reading = await block.read(signal)
        except NotFound as exc:
            raise CallRefused(f"{device}: {exc.message}", exc.code) from None
        if not isinstance(reading.value, bool):
            raise CallRefused(f"{name} is not a digital signal", "not_digital")
        return reading.value
    state = await run.devices.manager.state(device)
    index = int(signal[2:])
    values = state.get("digital_inputs" if signal.startswith("di") else "digital_outputs", [])
    if index >= len(values):
        raise CallRefused(f"{device} has no {signal}", "unknown_io")
    return bool(values[index])


async def set_analog(run: RunHost, args: dict[str, Any]) -> None:
    name = str(args["name"])
    device, kind, signal = await signal_of(run, name)
    if kind != "io":
        raise CallRefused(f"{device} has no analog outputs", "unknown_io")
    block = cast(IOClient, await run.device(device, "io"))
    try:
        await block.write(signal, SignalWrite(value=float(args["value"])))
    except (NotFound, InvalidValue) as exc:
        raise CallRefused(f"{device}: {exc.message}", exc.code) from None


async def get_analog(run: RunHost, args: dict[str, Any]) -> float:
    name = str(args["name"])
    device, kind, signal = await signal_of(run, name)
    if kind != "io":
        raise CallRefused(f"{device} has no analog signals", "unknown_io")
    block = cast(IOClient, await run.read_device(device, "io"))
    try:
        reading = await block.read(signal)
    except NotFound as exc:
        raise CallRefused(f"{device}: {exc.message}", exc.code) from None
    if reading.value is None:
        raise CallRefused(f"{name} is unknown: {device} does not answer", "device_disconnected")
    if isinstance(reading.value, bool):
        raise CallRefused(f"{name} is a digital signal", "not_analog")
    return reading.value


async def get_stored(run: RunHost, args: dict[str, Any]) -> dict[str, Any]:
    variable = await run.storage.get(checked_name(args["name"]))
    return {"type": variable.type, "value": variable.value}


async def set_stored(run: RunHost, args: dict[str, Any]) -> None:
    value = args["value"]
    kind = args.get("type") or _type_of(value)
    await put_value(run.storage, run.program, args["name"], str(kind), value)


def _type_of(value: Any) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "list"
    return "json"
