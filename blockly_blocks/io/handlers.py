"""The runtime's answers to the I/O blocks' calls (runtime/program/calls.py says how
they are written)."""

from __future__ import annotations

import re
from typing import Any, cast

from openpendant.runtime.clients.kinds import IOClient
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.interfaces.robot import DigitalOutputCommand
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.program.calls import DEVICE_NAME
from openpendant.runtime.program.host import RunHost
from openpendant.sandbox.supervisor import CallRefused

IO_NAME = re.compile(r"^([a-z][a-z0-9_]{0,31})\.(di|do)(\d{1,2})\Z")  # a robot's
SIGNAL = re.compile(r"^[a-z][a-z0-9_]{0,31}\Z")


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
