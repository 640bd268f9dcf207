"""The standard I/O block: named digital and analog signals, read, written with read-back, and
streamed in the state with the time each last changed (so a consumer that missed a state
still sees the change)."""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from typing import Literal

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver
from openpendant.runtime.interfaces.endpoints import endpoint

SIGNAL_NAME = r"^[a-z][a-z0-9_]{0,31}$"
SignalKind = Literal["digital_input", "digital_output", "analog_input", "analog_output"]
# A signal's value: a digital one is a bool, an analog one a float in its unit; None while it
# is unknown (the device did not answer): never the last value it had.
SignalValue = bool | float | None


class SignalInfo(BaseModel):
    name: str = Field(pattern=SIGNAL_NAME)
    kind: SignalKind
    unit: str = Field(default="", max_length=16)  # analog: "V", "mA", "bar", …
    minimum: float | None = None  # analog: the range a write must stay in
    maximum: float | None = None
    description: str = Field(default="", max_length=200)

    @property
    def writable(self) -> bool:
        return self.kind.endswith("_output")

    @property
    def digital(self) -> bool:
        return self.kind.startswith("digital")


class IOInfo(BaseModel):
    model: str
    signals: list[SignalInfo] = Field(max_length=1024)


class IODescription(BaseModel):
    identity: DeviceIdentity
    info: IOInfo


class IOState(BaseModel):
    seqno: int
    ts: float
    connected: bool
    values: dict[str, SignalValue] = Field(default_factory=dict)
    changed: dict[str, float] = Field(default_factory=dict)  # signal -> when it last changed
    error: str = ""


class SignalWrite(Strict):
    value: bool | float


class SignalReading(BaseModel):
    name: str
    value: SignalValue
    ts: float  # when it was read from the device


class IOBlock(ABC):
    """Digital and analog inputs and outputs by name."""

    @endpoint("GET", "/signals/{name}", returns=SignalReading)
    @abstractmethod
    async def read(self, name: str) -> SignalReading:
        """The signal read from the device now."""

    @endpoint(
        "PUT",
        "/signals/{name}",
        body=SignalWrite,
        returns=SignalReading,
        label=lambda name, body: f"write:{name}",
    )
    @abstractmethod
    async def write(self, name: str, command: SignalWrite) -> SignalReading:
        """Write an output, then read it back: the answer is what the device holds."""


class IODriver(KindDriver[IOInfo], IOBlock):
    description = IODescription

    @abstractmethod
    def state(self) -> IOState: ...


class SignalRecord:
    """What an I/O driver last knew of its signals, and when each last changed: its state.
    Mixed in before IODriver (it answers `state`)."""

    values: dict[str, SignalValue]
    changed: dict[str, float]
    connected: bool
    error: str
    seqno: int
    clock: Callable[[], float]
    state_changed: asyncio.Event | None

    def _start_record(self, names: Iterable[str], clock: Callable[[], float]) -> None:
        self.clock = clock
        self.values = dict.fromkeys(names)
        self.changed = {}
        self.connected, self.error = False, "not connected yet"
        self.seqno = 0
        self._changes = asyncio.Event()
        self.state_changed = self._changes  # the state stream sends a change at once

    def _record(self, values: dict[str, SignalValue], *, connected: bool, error: str) -> None:
        now = self.clock()
        different = (connected, error) != (self.connected, self.error)
        for name, value in values.items():
            if name not in self.changed or self.values.get(name) != value:
                self.changed[name] = now
                different = True
            self.values[name] = value
        self.connected, self.error = connected, error
        self.seqno += 1
        if different:
            self._changes.set()

    def state(self) -> IOState:
        return IOState(
            seqno=self.seqno,
            ts=self.clock(),
            connected=self.connected,
            values=dict(self.values),
            changed=dict(self.changed),
            error=self.error,
        )
