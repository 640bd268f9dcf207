"""The motion service for other services: plan or run a move, follow it, pause, stop."""

from __future__ import annotations

from openpendant.runtime.device_manager.client import LEASE_HEADER
from openpendant.runtime.kit.client import ServiceClient
from openpendant.runtime.motion.models import (
    MoveKind,
    MoveRequest,
    MoveState,
    MoveStatus,
    PlanReport,
    Target,
)

__all__ = [
    "MotionClient",
    "MoveKind",
    "MoveRequest",
    "MoveState",
    "MoveStatus",
    "PlanReport",
    "Target",
]

CALLER_HEADER = "X-Caller"
CLAIM_HEADER = "X-Claim"


class MotionClient:
    def __init__(self, base_url: str, timeout: float = 10.0) -> None:
        self.http = ServiceClient(base_url, timeout=timeout, name="motion")

    async def aclose(self) -> None:
        await self.http.aclose()

    async def plan(self, robot: str, request: MoveRequest) -> PlanReport:
        """Plan and check a move; nothing moves."""
        return await self.http.request(
            "POST",
            f"/motion/robots/{robot}/plan",
            json=request.model_dump(mode="json", exclude_none=True),
            model=PlanReport,
        )

    async def start(
        self,
        robot: str,
        request: MoveRequest,
        token: str,
        caller: str | None = None,
        claim: str | None = None,
    ) -> MoveStatus:
        """Start a move under the robot's lease; `caller` names who asks (a program run),
        so that a stop naming it refuses its later moves too; `claim` the claim the caller
        made on its own link to the device manager, without which the move reaches nothing."""
        headers = _headers(token, caller)
        if claim is not None:
            headers[CLAIM_HEADER] = claim
        return await self.http.request(
            "POST",
            f"/motion/robots/{robot}/moves",
            json=request.model_dump(mode="json", exclude_none=True),
            headers=headers,
            model=MoveStatus,
        )

    async def status(self, move_id: str, wait: float = 0.0) -> MoveStatus:
        """The move's status, once it changes or after `wait` seconds."""
        return await self.http.request(
            "GET",
            f"/motion/moves/{move_id}",
            params={"wait": wait},
            timeout=wait + 5.0,
            model=MoveStatus,
        )

    async def stop(self, robot: str, caller: str | None = None) -> None:
        await self.http.post(f"/motion/robots/{robot}/stop", headers=_headers(None, caller))

    async def pause(self, robot: str, caller: str | None = None) -> MoveStatus:
        return await self.http.request(
            "POST",
            f"/motion/robots/{robot}/pause",
            headers=_headers(None, caller),
            model=MoveStatus,
        )

    async def resume(self, robot: str, token: str | None, caller: str | None = None) -> MoveStatus:
        return await self.http.request(
            "POST",
            f"/motion/robots/{robot}/resume",
            headers=_headers(token, caller),
            model=MoveStatus,
        )


def _headers(token: str | None, caller: str | None) -> dict[str, str]:
    headers = {}
    if token is not None:
        headers[LEASE_HEADER] = token
    if caller is not None:
        headers[CALLER_HEADER] = caller
    return headers
