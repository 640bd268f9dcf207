"""What every device driver says about itself."""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from typing import ClassVar, Generic, TypeVar

from pydantic import BaseModel, Field

from openpendant.runtime.kit.api_version import API_VERSION


class DeviceIdentity(BaseModel):
    uuid: str = Field(min_length=1, max_length=64)
    # robot, camera, detector, io, gripper, input, or a kind a plugin declares
    kind: str = Field(pattern=r"^[a-z][a-z0-9_]{0,15}$")
    model: str = Field(max_length=64)
    name: str = Field(max_length=64)
    api: str = API_VERSION


class DeviceDriver(ABC):
    """What every driver has: an identity, a description, a state to stream."""

    def __init__(self, identity: DeviceIdentity) -> None:
        self.identity = identity
        # A driver whose state changes now and then (a polled input) makes this event and
        # sets it on a change: its stream sends the state at once, not at its next tick.
        # None for the others (a robot's state changes every cycle anyway).
        self.state_changed: asyncio.Event | None = None

    @property
    def kind(self) -> str:
        return self.identity.kind

    @abstractmethod
    def describe(self) -> BaseModel:
        """Identity and the kind's static information (served as GET /info)."""

    @abstractmethod
    def state(self) -> BaseModel:
        """The latest state; cheap enough to call at the streaming rate."""

    async def start(self) -> None:
        """Connect to the device (or start the simulation)."""

    async def shutdown(self) -> None:
        """Leave the device safe and release it."""


Info = TypeVar("Info", bound=BaseModel)


class KindDriver(DeviceDriver, Generic[Info]):
    """A driver of a kind whose GET /info is {identity, info}: `info` the kind's static
    information (a model), `description` the model of the whole."""

    description: ClassVar[type[BaseModel]]

    def __init__(self, identity: DeviceIdentity, info: Info) -> None:
        super().__init__(identity)
        self.info = info

    def describe(self) -> BaseModel:
        return self.description(identity=self.identity, info=self.info)
