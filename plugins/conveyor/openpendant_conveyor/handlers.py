"""The runtime's answers to the conveyor's sandbox calls, in the program service. Running the
belt needs its control lease (the run takes it, and stops the belt when it is stopped);
reading the sensor does not."""

from __future__ import annotations

import math
from typing import Any

from openpendant.plugins.api import RunContext
from openpendant.runtime.kit.errors import DeviceError, InvalidValue
from openpendant_conveyor.client import ConveyorClient
from openpendant_conveyor.interface import SpeedCommand


def _client(found: object) -> ConveyorClient:
    if not isinstance(found, ConveyorClient):
        raise DeviceError("that device is not a conveyor", code="not_a_conveyor")
    return found


async def run(host: RunContext, args: dict[str, Any]) -> None:
    speed = float(args["speed"])
    if not math.isfinite(speed):
        raise InvalidValue("the speed must be a finite number", code="not_finite")
    client = _client(await host.device(str(args["conveyor"]), "conveyor"))
    await client.run(SpeedCommand(speed=speed))


async def part(host: RunContext, args: dict[str, Any]) -> bool:
    client = _client(await host.read_device(str(args["conveyor"]), "conveyor"))
    return client.current().part_present
