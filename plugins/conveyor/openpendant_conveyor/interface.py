"""The conveyor: a device kind of this plugin's, on both sides of the wire like the standard
ones (the driver implements it, `ConveyorClient` calls it over the device's link)."""

from __future__ import annotations

from abc import ABC, abstractmethod

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver
from openpendant.runtime.interfaces.endpoints import endpoint


class ConveyorInfo(BaseModel):
    model: str
    length: float = Field(gt=0)  # m
    max_speed: float = Field(gt=0)  # m/s
    sensor_at: float = Field(ge=0)  # m from the belt's start: where parts stop and are seen


class ConveyorDescription(BaseModel):
    identity: DeviceIdentity
    info: ConveyorInfo


class ConveyorState(BaseModel):
    seqno: int
    ts: float
    connected: bool = True
    speed: float  # m/s, as it runs now (negative: backwards)
    position: float  # m the belt has travelled since the driver started
    part_present: bool  # a part waits at the sensor
    parts_taken: int = 0


class SpeedCommand(Strict):
    speed: float = Field(ge=-10.0, le=10.0)  # m/s


class Conveyor(ABC):
    @endpoint("PUT", "/speed", body=SpeedCommand, returns=ConveyorState)
    @abstractmethod
    async def run(self, command: SpeedCommand) -> ConveyorState:
        """Run at this speed (0 stops); over the conveyor's maximum is refused."""

    @endpoint("POST", "/stop", returns=ConveyorState)
    @abstractmethod
    async def stop(self) -> ConveyorState: ...


class ConveyorDriver(KindDriver[ConveyorInfo], Conveyor):
    description = ConveyorDescription

    @abstractmethod
    def state(self) -> ConveyorState: ...
