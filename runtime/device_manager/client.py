"""What other services ask the device manager over HTTP: is this lease token in control, and
an added robot's description. Links to devices go over the link socket (runtime/links)."""

from __future__ import annotations

from typing import Any

from runtime.interfaces.robot import RobotInfo
from runtime.kit.client import ServiceClient
from runtime.kit.errors import OpenPendantError


def require_token(name: str, token: str | None) -> str:
    if token is None:
        raise OpenPendantError(f"take control of {name} first", code="lease_required", status=409)
    return token


async def check_lease(devices: ServiceClient, name: str, token: str) -> dict[str, Any]:
    """The device manager's answer for a holder's token (which renews the lease), or its
    refusal raised."""
    granted: dict[str, Any] = await devices.request(
        "POST", f"/devices/{name}/lease/check", headers={"X-Lease-Token": token}
    )
    return granted


async def robot_info(devices: ServiceClient, name: str) -> RobotInfo:
    """An added robot's info, as the device manager has it from the driver."""
    details = await devices.get(f"/devices/{name}")
    return RobotInfo.model_validate(details["info"]["info"])
