"""API models of the device manager."""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from openpendant.runtime.interfaces.common import PlainText, Pose, Strict

LOCAL_NAME_PATTERN = r"^[a-z][a-z0-9_]{0,31}$"

ConnectionStatus = Literal["connecting", "connected", "stale", "disconnected"]
# How this runtime sees a device on the network (runtime/device_manager/announcements.py).
Mark = Literal["added", "paired", "elsewhere", "new"]
# Why a device is another's: it says another runtime started it, or it announces a uuid this
# runtime holds a pairing key for without that key (another device with its identity).
Elsewhere = Literal["other_runtime", "other_key"]


class DetectedDevice(BaseModel):
    """A device seen on the network. Text fields come from the device: untrusted."""

    uuid: str
    name: str
    kind: str
    model: str
    api: str
    address: str
    url: str
    added_as: str | None = None
    last_seen: float
    # Other addresses announcing the same uuid: an impostor, or the device's own old record.
    also_at: list[str] = Field(default_factory=list)
    # Added here (its uuid is one of this runtime's devices), paired with this runtime (it
    # holds the key the device announces), another's (why: `elsewhere`), or none of these.
    mark: Mark = "new"
    elsewhere: Elsewhere | None = None


class AddressClaim(BaseModel):
    """Another address an added device was seen at: announced there while its link was
    live (not followed: shown to the user), or where it was before it moved (followed)."""

    url: str
    name: str
    seen: float
    followed: bool = False
    # Not followed, though what answers there proved it is the device serving from that
    # address: a move that waits for the user (PUT /devices/{name}/address), since the link
    # was live or its robot was moving or in a fault.
    proven: bool = False


class AddedDevice(BaseModel):
    local_name: str
    uuid: str
    kind: str
    model: str
    name: str
    url: str
    status: ConnectionStatus
    last_error: str = ""
    connected_since: float | None = None
    detected: bool = False
    controlled_by: str | None = None
    control_expires: float | None = None
    link: int = 0  # the link's generation: a new one for every session
    state_age: float | None = None  # s, of the newest state, while connected
    address_claim: AddressClaim | None = None


class DeviceDetails(AddedDevice):
    info: dict[str, Any] | None = None


class RepointRequest(Strict):
    url: str = Field(pattern=r"^https?://[^\s/]+(:\d+)?/?$", max_length=256)


class AddDeviceRequest(Strict):
    """Add a detected device by uuid, or any device by its URL."""

    local_name: str
    uuid: str | None = Field(default=None, min_length=1, max_length=64)
    # The device's pairing code (a device on another computer prints it when it starts; one
    # this runtime started, or one started on this computer, is paired already).
    pairing: str | None = Field(
        default=None, min_length=16, max_length=128, pattern=r"^[A-Za-z0-9_-]+$"
    )
    url: str | None = Field(default=None, pattern=r"^https?://[^\s/]+(:\d+)?/?$", max_length=256)

    @field_validator("local_name")
    @classmethod
    def _local_name(cls, value: str) -> str:
        if not re.fullmatch(LOCAL_NAME_PATTERN, value):
            raise ValueError(
                "a local name starts with a lowercase letter and has only lowercase letters, "
                "digits and '_', at most 32 characters (it is used in programs)"
            )
        return value

    @model_validator(mode="after")
    def _one_of(self) -> AddDeviceRequest:
        if (self.uuid is None) == (self.url is None):
            raise ValueError("give either a uuid (of a detected device) or a url")
        return self


class LeaseRequest(Strict):
    holder: PlainText = Field(min_length=1, max_length=64)


class LeaseGranted(BaseModel):
    """Returned to the holder only: the token is what proves control."""

    device: str
    holder: str
    token: str
    expires: float


class LeaseInfo(BaseModel):
    device: str
    holder: str | None = None
    expires: float | None = None


class CellPart(BaseModel):
    """A part on a simulated cell's table, where it truly is (in the device's base frame)."""

    id: str
    size: list[float]  # m: x, y, z
    pose: Pose
    held: bool  # in the robot's fingers
    tag: int | None  # an ArUco id on its top face
