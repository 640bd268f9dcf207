"""A simulated conveyor: a belt that brings parts up to a stopper with a sensor. A new part is
put on the belt's start every `spacing` metres of travel; parts ride the belt until they
reach the stopper, or queue behind the part there. `POST /sim/take` takes the waiting part
away (what a robot's pick does to a real one)."""

from __future__ import annotations

import asyncio
import contextlib
import time

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import InvalidValue
from openpendant_conveyor.interface import (
    ConveyorDriver,
    ConveyorInfo,
    ConveyorState,
    SpeedCommand,
)

TICK = 0.02  # s
ACCELERATION = 1.0  # m/s²: speed changes this fast, so parts do not slide
PART = 0.05  # m a part takes on the belt
SEEN = 1e-6  # m: a part this close to the stopper is at the sensor


class SimConveyorOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    length: float = Field(default=2.0, gt=0, le=100, description="belt length, m")
    max_speed: float = Field(default=0.5, gt=0, le=10, description="m/s")
    sensor_at: float = Field(default=1.8, gt=0, description="stopper and sensor, m from start")
    spacing: float = Field(default=0.3, gt=PART, description="m of travel between new parts")

    def default_name(self) -> str:
        return "sim-conveyor"


class SimConveyor(ConveyorDriver):
    def __init__(self, identity: DeviceIdentity, options: SimConveyorOptions) -> None:
        if options.sensor_at > options.length:
            raise InvalidValue("the sensor must be on the belt (sensor_at ≤ length)")
        info = ConveyorInfo(
            model="sim-conveyor",
            length=options.length,
            max_speed=options.max_speed,
            sensor_at=options.sensor_at,
        )
        super().__init__(identity, info)
        self.spacing = options.spacing
        self.speed = 0.0
        self.target = 0.0
        self.position = 0.0
        self.since_part = options.spacing  # the first part is put on at once
        self.parts: list[float] = []  # positions on the belt, the one nearest the sensor first
        self.taken = 0
        self.seqno = 0
        self.ts = time.time()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        self._task = asyncio.create_task(self._run())

    async def shutdown(self) -> None:
        self.target = self.speed = 0.0
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    def state(self) -> ConveyorState:
        return ConveyorState(
            seqno=self.seqno,
            ts=self.ts,
            speed=self.speed,
            position=self.position,
            part_present=self.part_present,
            parts_taken=self.taken,
        )

    @property
    def part_present(self) -> bool:
        return bool(self.parts) and self.parts[0] >= self.info.sensor_at - SEEN

    async def run(self, command: SpeedCommand) -> ConveyorState:
        if abs(command.speed) > self.info.max_speed:
            raise InvalidValue(
                f"{abs(command.speed) * 1000:.0f} mm/s is over the conveyor's "
                f"{self.info.max_speed * 1000:.0f} mm/s"
            )
        self.target = command.speed
        return self.state()

    async def stop(self) -> ConveyorState:
        self.target = 0.0
        return self.state()

    def take(self) -> ConveyorState:
        if not self.part_present:
            raise InvalidValue("no part waits at the sensor")
        self.parts.pop(0)
        self.taken += 1
        return self.state()

    def step(self, dt: float) -> None:
        most = ACCELERATION * dt
        self.speed += max(-most, min(most, self.target - self.speed))
        travel = self.speed * dt
        self.position += travel
        limit = self.info.sensor_at
        moved = []
        for part in self.parts:
            part = min(max(part + travel, 0.0), limit)
            moved.append(part)
            limit = part - PART
        self.parts = [p for p in moved if p >= 0.0]
        if travel > 0:
            self.since_part += travel
            room = not self.parts or self.parts[-1] >= PART
            if self.since_part >= self.spacing and room:
                self.parts.append(0.0)
                self.since_part = 0.0
        self.seqno += 1
        self.ts = time.time()

    async def _run(self) -> None:
        last = time.monotonic()
        while True:
            await asyncio.sleep(TICK)
            now = time.monotonic()
            self.step(min(now - last, 0.1))
            last = now


def create(name: str, uuid: str, options: SimConveyorOptions) -> SimConveyor:
    identity = DeviceIdentity(uuid=uuid, kind="conveyor", model="sim-conveyor", name=name)
    return SimConveyor(identity, options)


def routes(driver: SimConveyor) -> APIRouter:
    """What a simulator has and a conveyor does not."""
    router = APIRouter(prefix="/sim")

    @router.post("/take")
    async def take() -> ConveyorState:
        """Take the part waiting at the sensor away (a robot picked it)."""
        return driver.take()

    return router
