"""HID reports to axes and buttons, and the operator's settings: dead zone, sensitivity,
which raw axis drives which output axis, inversion."""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, Field, field_validator

from openpendant.runtime.interfaces.input import AXES

FULL_SCALE = 350.0  # raw counts at full deflection


class ReportError(ValueError):
    pass


@dataclass(frozen=True)
class RawInput:
    """What one report carried; None for the parts it did not carry."""

    translation: tuple[int, int, int] | None = None
    rotation: tuple[int, int, int] | None = None
    buttons: frozenset[int] | None = None


def parse_report(report: bytes) -> RawInput | None:
    """One HID input report (report id first). None for reports that carry no input
    (battery level, LED state, ...)."""
    if not report:
        raise ReportError("empty report")
    report_id, payload = report[0], report[1:]
    if report_id == 1 and len(payload) >= 12:
        values = struct.unpack_from("<6h", payload)
        return RawInput(translation=values[:3], rotation=values[3:])
    if report_id in (1, 2):
        if len(payload) < 6:
            raise ReportError(f"report {report_id} has {len(payload)} bytes, expected 6")
        values3 = struct.unpack_from("<3h", payload)
        return RawInput(translation=values3) if report_id == 1 else RawInput(rotation=values3)
    if report_id == 3:
        bits = int.from_bytes(payload, "little")
        return RawInput(buttons=frozenset(i for i in range(len(payload) * 8) if bits >> i & 1))
    return None


class AxisSettings(BaseModel):
    """Right-handed by default: x to the right, y away from the operator, z up, and the
    rotations about those axes; the raw HID axes have y toward the operator and z down."""

    dead_zone: float = Field(default=0.05, ge=0, lt=1)
    sensitivity: list[float] = Field(default_factory=lambda: [1.0] * 6)
    source_axis: list[int] = Field(default_factory=lambda: list(range(6)))
    invert: list[str] = Field(default_factory=lambda: ["y", "z", "ry", "rz"])

    @field_validator("sensitivity")
    @classmethod
    def _six_gains(cls, value: list[float]) -> list[float]:
        if len(value) != 6 or any(not 0 < g <= 10 for g in value):
            raise ValueError("six sensitivities in (0, 10]")
        return value

    @field_validator("source_axis")
    @classmethod
    def _permutation(cls, value: list[int]) -> list[int]:
        if sorted(value) != list(range(6)):
            raise ValueError("source_axis must name each raw axis 0-5 once")
        return value

    @field_validator("invert")
    @classmethod
    def _axis_names(cls, value: list[str]) -> list[str]:
        unknown = set(value) - set(AXES)
        if unknown:
            raise ValueError(f"unknown axes: {', '.join(sorted(unknown))}")
        return value


class AxisFilter:
    def __init__(self, settings: AxisSettings) -> None:
        self.dead_zone = settings.dead_zone
        self.gain = np.array(settings.sensitivity)
        self.order = np.array(settings.source_axis)
        self.sign = np.array([-1.0 if a in settings.invert else 1.0 for a in AXES])

    def apply(self, raw: np.ndarray) -> list[float]:
        """Raw counts [x, y, z, rx, ry, rz] to axes in [-1, 1]."""
        value = np.clip(raw[self.order] / FULL_SCALE, -1.0, 1.0)
        magnitude = np.abs(value)
        # Outside the dead zone the response starts from zero, so there is no jump.
        shaped = np.where(
            magnitude < self.dead_zone, 0.0, (magnitude - self.dead_zone) / (1.0 - self.dead_zone)
        )
        result = np.clip(np.sign(value) * shaped * self.gain, -1.0, 1.0) * self.sign
        return [float(v) + 0.0 for v in result]  # + 0.0: no negative zeros in the JSON
