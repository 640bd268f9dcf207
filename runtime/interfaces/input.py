"""The standard input device (a 3D mouse): six axes in [-1, 1] and buttons, streamed."""

from __future__ import annotations

from abc import ABC, abstractmethod

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver

AXES = ("x", "y", "z", "rx", "ry", "rz")


class InputInfo(BaseModel):
    model: str
    vendor_id: int | None = None
    product_id: int | None = None
    buttons: int = 0
    axes: list[str] = Field(default_factory=lambda: list(AXES))
    source: str = ""


class InputDescription(BaseModel):
    identity: DeviceIdentity
    info: InputInfo


class InputState(BaseModel):
    """`ts` is when the device last reported. A deflected device keeps reporting; one that
    stops while deflected is stuck or gone, and must not keep a robot moving."""

    seqno: int
    ts: float
    axes: list[float] = Field(min_length=6, max_length=6)
    buttons: list[int] = Field(default_factory=list)  # numbers of the buttons held down
    connected: bool
    error: str = ""


class InputDevice(ABC):  # noqa: B024 (no commands: its state is all it has)
    """An input device has no commands: six axes and its buttons, streamed."""


class InputDriver(KindDriver[InputInfo], InputDevice):
    description = InputDescription

    @abstractmethod
    def state(self) -> InputState: ...
