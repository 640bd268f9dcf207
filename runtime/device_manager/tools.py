"""What each robot carries: its tool setup (TCP and payload), stored as the variable
`tools.<robot>` and applied to the driver on every connect and whenever it is changed, so
the TCP the driver reports and the one jogging, moves and waypoints use are the same."""

from __future__ import annotations

from typing import Any

import httpx

from openpendant.runtime.interfaces.endpoints import endpoints
from openpendant.runtime.interfaces.robot import Robot, ToolSetup
from openpendant.runtime.kit.errors import NotFound, OpenPendantError
from openpendant.runtime.variable_storage.client import StorageClient

TOOL_PREFIX = "tools."
CALL_TIMEOUT = 5.0


def tool_variable(robot: str) -> str:
    return TOOL_PREFIX + robot


async def stored_tool(storage: StorageClient, robot: str) -> dict[str, Any] | None:
    """The robot's stored tool setup, None if it has none."""
    try:
        variable = await storage.get(tool_variable(robot))
    except NotFound:
        return None
    return ToolSetup.model_validate(variable.value).model_dump()


async def send_tool_setup(http: httpx.AsyncClient, setup: dict[str, Any]) -> dict[str, Any]:
    """The robot interface's `set_tool_setup` on the driver's connection; its new description
    (as GET /info gives it)."""
    ep = endpoints(Robot)["set_tool_setup"]
    response = await http.request(ep.method, ep.url(), json=setup, timeout=CALL_TIMEOUT)
    try:
        body = response.json()
    except ValueError:
        body = None
    if response.status_code != 200 or not isinstance(body, dict):
        error = body.get("error", {}) if isinstance(body, dict) else {}
        message = error.get("message") if isinstance(error, dict) else None
        raise OpenPendantError(
            f"the robot refused the tool setup: {message or f'HTTP {response.status_code}'}",
            code=(error.get("code") if isinstance(error, dict) else None) or "tool_refused",
            status=response.status_code if 400 <= response.status_code < 500 else 502,
        )
    return body
