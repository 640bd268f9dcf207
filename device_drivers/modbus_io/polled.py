"""What every polled Modbus device driver does on start and shutdown: its simulated device
first (`--simulate`), then a poll at a steady rate; on shutdown the reverse."""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

from openpendant.device_drivers.modbus_io.link import ModbusLink, poll_forever
from openpendant.runtime.kit.tasks import cancel_for_sure

if TYPE_CHECKING:
    from openpendant.device_drivers.modbus_io.simulator import ModbusSimulator


class Polled(ABC):
    period: float
    link: ModbusLink
    simulator: ModbusSimulator | None
    _poller: asyncio.Task[None] | None = None

    @abstractmethod
    async def poll_once(self) -> None:
        """Read the device once and update the state (errors become the state's, not raised)."""

    async def start(self) -> None:
        if self.simulator is not None:
            await self.simulator.start()
            self.link.address = self.simulator.address  # its port is known once it listens
        self._poller = asyncio.create_task(poll_forever(self.period, self.poll_once))

    async def shutdown(self) -> None:
        if self._poller is not None:
            await cancel_for_sure(self._poller)  # it is mostly inside a request
        self.link.close()
        if self.simulator is not None:
            await self.simulator.stop()
