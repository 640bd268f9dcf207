"""The runtime's answers to the waypoint blocks' calls (runtime/program/calls.py says how
they are written)."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.kit.errors import NotFound
from openpendant.runtime.kit.words import words
from openpendant.runtime.program.host import RunHost
from openpendant.sandbox.supervisor import CallRefused

WAYPOINT_TYPES = ("joint_waypoint", "pose_waypoint")


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
