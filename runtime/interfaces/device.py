"""What every device driver says about itself."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from runtime.kit.discovery import API_VERSION

DeviceKind = Literal["robot", "camera", "detector", "io", "gripper", "input"]


class DeviceIdentity(BaseModel):
    uuid: str = Field(min_length=1, max_length=64)
    kind: DeviceKind
    model: str = Field(max_length=64)
    name: str = Field(max_length=64)
    api: str = API_VERSION
