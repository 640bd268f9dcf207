"""Typed client of the vision service for other services (a program's detect blocks)."""

from __future__ import annotations

from functools import cache
from urllib.parse import quote

from openpendant.runtime.interfaces.detector import DetectRequest
from openpendant.runtime.kit.client import ServiceClient
from openpendant.runtime.services import urls_from_env
from openpendant.runtime.vision.models import LocatedDetections

DETECT_TIMEOUT = 30.0  # s: a frame, a detection and the poses


class VisionClient:
    def __init__(self, base_url: str) -> None:
        self.http = ServiceClient(base_url, timeout=DETECT_TIMEOUT, name="vision")

    async def aclose(self) -> None:
        await self.http.aclose()

    async def detect(self, detector: str, request: DetectRequest) -> LocatedDetections:
        return await self.http.request(
            "POST",
            f"/vision/detectors/{quote(detector, safe='')}/detect",
            json=request.model_dump(mode="json"),
            model=LocatedDetections,
        )


@cache
def vision_client() -> VisionClient:
    """This process's client of the runtime's vision service."""
    return VisionClient(urls_from_env()["vision"])
