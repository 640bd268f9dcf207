"""A 3Dconnexion SpaceMouse as the driver host serves it (`openpendant driver spacemouse`)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from fastapi import APIRouter, Response
from pydantic import BaseModel, ConfigDict, Field

from openpendant.device_drivers.spacemouse.driver import SpaceMouseDriver
from openpendant.device_drivers.spacemouse.reports import AxisSettings
from openpendant.device_drivers.spacemouse.sources import (
    HidSource,
    ReplaySource,
    ReportSource,
    SpacenavdSource,
)
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.input import AXES, InputInfo
from openpendant.runtime.kit.errors import InvalidValue


class SpaceMouseOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    source: Literal["hid", "spacenavd", "replay"] = Field(
        default="hid", description="hidapi, spacenavd's socket, or a recording"
    )
    replay: Path | None = Field(default=None, description="recording to play (source replay)")
    replay_wait: bool = Field(default=False, description="play only on POST /replay/start")
    socket: str = Field(default="/var/run/spnav.sock", description="spacenavd's socket")
    vendor: int | None = Field(default=None, description="USB vendor id")
    product: int | None = Field(default=None, description="USB product id")
    dead_zone: float = Field(default=0.05, ge=0, lt=1, description="fraction of full deflection")
    sensitivity: list[float] = Field(
        default=[1.0] * 6, min_length=6, max_length=6, description="six gains, x y z rx ry rz"
    )
    source_axis: list[int] = Field(
        default=[0, 1, 2, 3, 4, 5],
        min_length=6,
        max_length=6,
        description="which raw axis drives x y z rx ry rz",
    )
    invert: list[str] = Field(
        default=["y", "z", "ry", "rz"], description="axes to invert (empty for none)"
    )

    def default_name(self) -> str:
        return "spacemouse"


def _source(options: SpaceMouseOptions) -> ReportSource:
    if options.source == "replay":
        if options.replay is None or not options.replay.is_file():
            raise InvalidValue("--source replay needs --replay FILE")
        return ReplaySource(options.replay, wait_for_start=options.replay_wait)
    if options.source == "spacenavd":
        return SpacenavdSource(options.socket)
    return HidSource(options.vendor, options.product)


def create(name: str, uuid: str, options: SpaceMouseOptions) -> SpaceMouseDriver:
    try:
        settings = AxisSettings(
            dead_zone=options.dead_zone,
            sensitivity=options.sensitivity,
            source_axis=options.source_axis,
            invert=options.invert,
        )
    except ValueError as exc:
        raise InvalidValue(str(exc)) from exc
    identity = DeviceIdentity(uuid=uuid, kind="input", model="spacemouse", name=name)
    info = InputInfo(model="SpaceMouse", axes=list(AXES), source=options.source)
    return SpaceMouseDriver(
        identity, info, _source(options), settings, reopen=options.source != "replay"
    )


def routes(driver: SpaceMouseDriver) -> APIRouter:
    """A recording replays from its start on request (tests and demonstrations)."""
    router = APIRouter(prefix="/replay")
    source = driver.source
    if isinstance(source, ReplaySource):

        @router.post("/start", status_code=204)
        async def start() -> Response:
            source.restart()
            return Response(status_code=204)

    return router
