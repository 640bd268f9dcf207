"""The device manager for other services: the added devices, their newest states, and the
control leases. Commands to devices go over their links (runtime/clients), not here."""

from __future__ import annotations

from typing import Any

from openpendant.runtime.device_manager.models import AddedDevice, DeviceDetails, LeaseGranted

__all__ = ["AddedDevice", "DeviceDetails", "DeviceManagerClient", "LeaseGranted", "require_token"]
from openpendant.runtime.kit.client import ServiceClient
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.words import words

LEASE_HEADER = "X-Lease-Token"


def require_token(name: str, token: str | None) -> str:
    if token is None:
        raise OpenPendantError(
            f"take control of {name} first",
            code="lease_required",
            status=409,
            words=words("lease.required", device=name),
        )
    return token


class DeviceManagerClient:
    def __init__(self, base_url: str, timeout: float = 3.0) -> None:
        self.http = ServiceClient(base_url, timeout=timeout, name="device manager")

    async def aclose(self) -> None:
        await self.http.aclose()

    async def devices(self) -> list[AddedDevice]:
        found = await self.http.get("/devices")
        return [AddedDevice.model_validate(d) for d in found]

    async def device(self, name: str) -> DeviceDetails:
        return await self.http.request("GET", f"/devices/{name}", model=DeviceDetails)

    async def state(self, name: str) -> dict[str, Any]:
        """The device's newest state, as it streams it (empty while there is none)."""
        state: dict[str, Any] = await self.http.get(f"/devices/{name}/state") or {}
        return state

    async def take_lease(self, name: str, holder: str) -> LeaseGranted:
        return await self.http.request(
            "POST", f"/devices/{name}/lease", json={"holder": holder}, model=LeaseGranted
        )

    async def check_lease(self, name: str, token: str) -> LeaseGranted:
        """The holder's lease (a check renews it), or the refusal raised."""
        return await self.http.request(
            "POST",
            f"/devices/{name}/lease/check",
            headers={LEASE_HEADER: token},
            model=LeaseGranted,
        )

    async def release_lease(self, name: str, token: str) -> None:
        await self.http.delete(f"/devices/{name}/lease", headers={LEASE_HEADER: token})
