"""Models shared by every interface. Every float that crosses a boundary is finite."""

from __future__ import annotations

import math
import unicodedata
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, field_validator

# No cell is a kilometre across: a position beyond this is a typo or an attack, and numbers
# like 1e300 overflow the kinematics.
MAX_POSITION = 1000.0  # m

Position = Annotated[float, Field(ge=-MAX_POSITION, le=MAX_POSITION)]
Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Quaternion = Annotated[list[float], Field(min_length=4, max_length=4)]
JointVector = Annotated[list[float], Field(min_length=1, max_length=64)]


class Strict(BaseModel):
    """Input model: unknown fields and non-finite numbers are errors."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Pose(Strict):
    """Position in metres, orientation as a unit quaternion [qx, qy, qz, qw] (scalar last)."""

    position: Annotated[list[Position], Field(min_length=3, max_length=3)] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0]
    )
    orientation: Quaternion = Field(default_factory=lambda: [0.0, 0.0, 0.0, 1.0])

    @field_validator("orientation")
    @classmethod
    def _unit(cls, q: list[float]) -> list[float]:
        norm = math.sqrt(sum(c * c for c in q))
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f"orientation must be a unit quaternion (norm {norm:.6g})")
        return [c / norm for c in q]


def plain_text(value: str) -> str:
    """Text a person reads as it is: no control, format (bidi overrides, zero-width) or
    unassigned characters, which could hide or reorder what is shown."""
    for char in value:
        if unicodedata.category(char) in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"):
            raise ValueError(f"holds the character U+{ord(char):04X}, which is not shown as text")
    return value


PlainText = Annotated[str, AfterValidator(plain_text)]


def all_finite(value: object, depth: int = 0) -> bool:
    """True when every number inside a JSON-like value is finite."""
    if depth > 64:
        return False
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(all_finite(v, depth + 1) for v in value.values())
    if isinstance(value, list | tuple):
        return all(all_finite(v, depth + 1) for v in value)
    return True
