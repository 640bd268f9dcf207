"""A gripper on plain digital I/O of a Modbus block (a pneumatic or simple electric gripper
behind valves): an output that closes it, optionally one that opens it, and optionally
inputs that say it holds a part or is open. Its register map names those signals `close`,
`open`, `gripped` and `opened`.

It has no position and no motion to stop: STOP leaves its outputs as they are, so a held
part is not dropped."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from pathlib import Path

import yaml
from pydantic import Field, ValidationError, model_validator

from openpendant.device_drivers.modbus_io.driver import ModbusIODriver
from openpendant.device_drivers.modbus_io.registers import RegisterMap
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.gripper import (
    GripperDriver,
    GripperInfo,
    GripperMotion,
    GripperState,
)
from openpendant.runtime.interfaces.io import SignalWrite
from openpendant.runtime.kit.bounded_yaml import load_yaml
from openpendant.runtime.kit.errors import InvalidValue

ROLES = {
    "close": "coil",
    "open": "coil",
    "gripped": "discrete_input",
    "opened": "discrete_input",
}
CHECK_PERIOD = 0.02  # s between looks at the inputs while it moves


class DigitalGripperMap(RegisterMap):
    model: str = Field(default="Digital I/O gripper", max_length=64)
    stroke: float = Field(default=0.05, gt=0, le=1)  # m, fully open
    # What an open or close takes when no input says it is done (s).
    move_time: float = Field(default=0.5, gt=0, le=10)

    @model_validator(mode="after")
    def _roles(self) -> DigitalGripperMap:
        tables = {s.name: s.table for s in self.signals}
        if "close" not in tables:
            raise ValueError("a digital gripper needs a `close` output (a coil)")
        for name, table in tables.items():
            if name in ROLES and ROLES[name] != table:
                raise ValueError(f"`{name}` must be a {ROLES[name].replace('_', ' ')}")
        return self


def load_gripper_map(path: Path) -> DigitalGripperMap:
    try:
        return DigitalGripperMap.model_validate(load_yaml(path.read_text()))
    except (OSError, yaml.YAMLError, ValidationError) as exc:
        raise InvalidValue(f"gripper map {path}: {exc}") from exc


class DigitalGripper(GripperDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        block: ModbusIODriver,
        registers: DigitalGripperMap,
        *,
        clock: Callable[[], float] = time.time,
    ) -> None:
        names = {s.name for s in registers.signals}
        info = GripperInfo(
            model=registers.model,
            stroke=registers.stroke,
            capabilities=["object_detection"] if "gripped" in names else [],
        )
        super().__init__(identity, info)
        self.block, self.map, self.clock = block, registers, clock
        self.has = names
        self.simulator = block.simulator
        self._moving_until = 0.0  # monotonic time a move without an end input is taken as over

    async def _set(self, name: str, value: bool) -> None:
        if name in self.has:
            await self.block.write(name, SignalWrite(value=value))

    async def _follow(self, done_input: str, want: bool) -> None:
        """Until `done_input` reads `want`, or the move time is over when there is none or
        it never comes (a closing gripper with nothing to grip never reports a grip)."""
        deadline = time.monotonic() + self.map.move_time
        self._moving_until = deadline
        while time.monotonic() < deadline:
            if done_input in self.has:
                reading = await self.block.read(done_input)
                if reading.value is want:
                    break
            await asyncio.sleep(CHECK_PERIOD)
        self._moving_until = 0.0

    async def activate(self) -> GripperState:
        return self.state()  # nothing to activate: valves are ready when powered

    async def open(self, motion: GripperMotion) -> GripperState:
        await self._set("close", False)
        await self._set("open", True)
        await self._follow("opened", True)
        return await self._settled()

    async def close(self, motion: GripperMotion) -> GripperState:
        await self._set("open", False)
        await self._set("close", True)
        await self._follow("gripped", True)
        return await self._settled()

    async def _settled(self) -> GripperState:
        """The state as the inputs read now: the block's last poll may be older than the
        move (an open reported "holds a part" from before it opened)."""
        await self.block.poll_once()
        return self.state()

    async def move(self, motion: GripperMotion) -> GripperState:
        raise InvalidValue(
            f"the {self.map.model} only opens and closes: it has no positions",
            code="not_supported",
        )

    async def stop(self) -> GripperState:
        return self.state()

    def state(self) -> GripperState:
        io = self.block.state()
        values = io.values
        opened = values.get("opened")
        known = io.connected and not io.error
        return GripperState(
            seqno=io.seqno,
            ts=self.clock(),
            connected=known,
            activated=known,
            position=self.map.stroke if opened is True else None,
            moving=time.monotonic() < self._moving_until,
            object_detected=values.get("gripped") is True,
            fault=io.error,
        )

    async def start(self) -> None:
        await self.block.start()

    async def shutdown(self) -> None:
        await self.block.shutdown()
