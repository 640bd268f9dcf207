"""The standard gripper: activate, open, close or move to a width, with speed and force where
the gripper has them, and whether it holds an object."""

from __future__ import annotations

from abc import ABC, abstractmethod

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver
from openpendant.runtime.interfaces.endpoints import endpoint


class GripperInfo(BaseModel):
    model: str
    stroke: float = Field(gt=0)  # m, fully open
    max_speed: float | None = Field(default=None, gt=0)  # m/s; None: not settable
    max_force: float | None = Field(default=None, gt=0)  # N; None: not settable
    # "position" (moves to a width), "object_detection"
    capabilities: list[str] = Field(default_factory=list)


class GripperDescription(BaseModel):
    identity: DeviceIdentity
    info: GripperInfo


class GripperState(BaseModel):
    seqno: int
    ts: float
    connected: bool
    activated: bool
    position: float | None = None  # m of opening; None while unknown
    moving: bool = False
    object_detected: bool = False
    fault: str = ""  # empty when there is none


class GripperMotion(Strict):
    """Where, how fast and how hard; what is left out takes the gripper's default."""

    position: float | None = Field(default=None, ge=0)  # m, only for `move`
    speed: float | None = Field(default=None, gt=0)  # m/s
    force: float | None = Field(default=None, gt=0)  # N


class Gripper(ABC):
    @endpoint("POST", "/activate", returns=GripperState)
    @abstractmethod
    async def activate(self) -> GripperState:
        """Make it ready (some grippers open and close once to find their stroke)."""

    @endpoint("POST", "/open", body=GripperMotion, returns=GripperState)
    @abstractmethod
    async def open(self, motion: GripperMotion) -> GripperState: ...

    @endpoint("POST", "/close", body=GripperMotion, returns=GripperState)
    @abstractmethod
    async def close(self, motion: GripperMotion) -> GripperState:
        """Close until fully closed or stopped by an object (then `object_detected`)."""

    @endpoint("POST", "/move", body=GripperMotion, returns=GripperState)
    @abstractmethod
    async def move(self, motion: GripperMotion) -> GripperState:
        """To `position`, for grippers with the "position" capability."""

    @endpoint("POST", "/stop", returns=GripperState)
    @abstractmethod
    async def stop(self) -> GripperState: ...


class GripperDriver(KindDriver[GripperInfo], Gripper):
    description = GripperDescription

    @abstractmethod
    def state(self) -> GripperState: ...
