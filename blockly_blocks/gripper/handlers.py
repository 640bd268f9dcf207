"""The runtime's answers to the gripper blocks (runtime/program/calls.py says how they
are written)."""

from __future__ import annotations

import math
from typing import Any, cast

from openpendant.runtime.clients.kinds import GripperClient
from openpendant.runtime.interfaces.gripper import GripperMotion
from openpendant.runtime.kit.errors import NotFound, OpenPendantError
from openpendant.runtime.program.calls import DEVICE_NAME
from openpendant.runtime.program.host import RunHost
from openpendant.sandbox.supervisor import CallRefused


async def _gripper(run: RunHost, args: dict[str, Any], *, command: bool) -> GripperClient:
    name = str(args["gripper"])
    if not DEVICE_NAME.match(name):
        raise CallRefused(f"{name[:40]!r} is not a device name", "unknown_device")
    try:
        kind = (await run.devices.manager.device(name)).kind
    except NotFound:
        raise CallRefused(f"there is no gripper {name!r}", "unknown_device") from None
    if kind != "gripper":
        raise CallRefused(f"{name} is a {kind}, not a gripper", "not_a_gripper")
    client = await (run.device(name, "gripper") if command else run.read_device(name, "gripper"))
    return cast(GripperClient, client)


async def _motion(run: RunHost, name: str, close: bool) -> None:
    client = await _gripper(run, {"gripper": name}, command=True)
    motion = GripperMotion(force=run.gripper_force.get(name))
    try:
        state = await (client.close(motion) if close else client.open(motion))
    except OpenPendantError as exc:
        raise CallRefused(f"{name}: {exc.message}", exc.code) from None
    if state.fault:
        raise CallRefused(f"{name}: {state.fault}", "gripper_fault")


async def gripper_activate(run: RunHost, args: dict[str, Any]) -> None:
    name = str(args["gripper"])
    client = await _gripper(run, args, command=True)
    state = (await client.ready()).current()
    if state.activated:
        return  # a second activation would move the fingers for nothing
    try:
        state = await client.activate()
    except OpenPendantError as exc:
        raise CallRefused(f"{name}: {exc.message}", exc.code) from None
    if state.fault:
        raise CallRefused(f"{name}: {state.fault}", "gripper_fault")


async def gripper_open(run: RunHost, args: dict[str, Any]) -> None:
    await _motion(run, str(args["gripper"]), close=False)


async def gripper_close(run: RunHost, args: dict[str, Any]) -> None:
    await _motion(run, str(args["gripper"]), close=True)


async def gripper_force(run: RunHost, args: dict[str, Any]) -> None:
    client = await _gripper(run, args, command=False)
    force = float(args["force"])
    limit = client.description["info"].get("max_force")
    if limit is None:
        raise CallRefused(f"{args['gripper']} has no force setting", "not_supported")
    if not math.isfinite(force) or not 0 < force <= limit:
        raise CallRefused(f"{args['gripper']} takes a force up to {limit:g} N", "invalid_value")
    run.gripper_force[str(args["gripper"])] = force


async def gripper_holds(run: RunHost, args: dict[str, Any]) -> bool:
    client = await _gripper(run, args, command=False)
    try:
        state = (await client.ready()).current()
    except OpenPendantError as exc:
        raise CallRefused(f"{args['gripper']}: {exc.message}", exc.code) from None
    if not state.connected:
        raise CallRefused(f"{args['gripper']}: {state.fault}", "device_disconnected")
    return state.object_detected
