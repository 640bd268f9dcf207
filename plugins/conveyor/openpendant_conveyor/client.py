"""A service's conveyor, over the device manager's link to it."""

from __future__ import annotations

from typing import ClassVar

from openpendant.runtime.clients.base import DeviceClient
from openpendant_conveyor.interface import Conveyor, ConveyorInfo, ConveyorState, SpeedCommand


class ConveyorClient(DeviceClient[ConveyorState], Conveyor):
    kind: ClassVar[str] = "conveyor"
    state_model = ConveyorState

    @property
    def info(self) -> ConveyorInfo:
        return ConveyorInfo.model_validate(self.description["info"])

    async def run(self, command: SpeedCommand) -> ConveyorState:
        return await self._call(Conveyor.run, command)

    async def stop(self) -> ConveyorState:
        return await self._call(Conveyor.stop)
