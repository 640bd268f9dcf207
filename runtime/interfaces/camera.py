"""The standard camera: what it is (with its intrinsics once calibrated), one frame captured
on request, and a stream of frames at the consumer's pace."""

from __future__ import annotations

import base64
from abc import ABC, abstractmethod
from dataclasses import asdict, dataclass
from typing import Any, Literal

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver
from openpendant.runtime.interfaces.endpoints import endpoint

Encoding = Literal["jpeg", "png"]
ENCODINGS: tuple[Encoding, ...] = ("jpeg", "png")


class Intrinsics(BaseModel):
    """The pinhole model with OpenCV's distortion coefficients (k1, k2, p1, p2, k3, …)."""

    width: int = Field(gt=0)
    height: int = Field(gt=0)
    fx: float = Field(gt=0)
    fy: float = Field(gt=0)
    cx: float
    cy: float
    distortion: list[float] = Field(default_factory=list, max_length=14)


class CameraInfo(BaseModel):
    model: str
    width: int = Field(gt=0)
    height: int = Field(gt=0)
    fps: float = Field(gt=0)
    intrinsics: Intrinsics | None = None  # None until calibrated, or unknown
    encodings: list[Encoding] = Field(default_factory=lambda: list(ENCODINGS))


class CameraDescription(BaseModel):
    identity: DeviceIdentity
    info: CameraInfo


class CameraState(BaseModel):
    seqno: int
    ts: float
    connected: bool
    frames: int = 0  # captured since start
    last_frame: float | None = None  # when the newest frame was taken
    error: str = ""


class CaptureRequest(Strict):
    encoding: Encoding = "jpeg"
    quality: int = Field(default=90, ge=1, le=100)  # JPEG only


class Image(BaseModel):
    """One frame: `ts` is when it was taken, `data` the encoded image in base64."""

    seqno: int
    ts: float
    width: int
    height: int
    encoding: Encoding
    data: str


@dataclass(frozen=True)
class Frame:
    """One encoded frame as the frame stream sends it: an Image's fields, its bytes as they
    are (base64 is for the JSON of `POST /capture` only)."""

    seqno: int
    ts: float
    width: int
    height: int
    encoding: Encoding
    data: bytes

    def header(self) -> dict[str, Any]:
        """The stream's text message before the bytes."""
        fields = asdict(self)
        del fields["data"]
        return fields

    def image(self) -> Image:
        return Image(**self.header(), data=base64.b64encode(self.data).decode())


class Camera(ABC):
    """Frames are also streamed over `WS /frames/ws`: per frame a text message (the frame's
    fields but `data`, as JSON) and a binary one (the encoded image), the next sent only
    after the consumer acknowledges the last, so old frames never queue."""

    @endpoint("POST", "/capture", body=CaptureRequest, returns=Image)
    @abstractmethod
    async def capture(self, request: CaptureRequest) -> Image:
        """A new frame, taken after the request arrived."""


class CameraDriver(KindDriver[CameraInfo], Camera):
    description = CameraDescription

    async def frame(self, request: CaptureRequest) -> Frame:
        """The frame stream's next frame. A driver that encodes its frames itself gives their
        bytes as they are (`runtime/imaging/encoding.py`); by default, `capture()`'s."""
        image = await self.capture(request)
        fields = image.model_dump(exclude={"data"})
        return Frame(**fields, data=base64.b64decode(image.data))

    @abstractmethod
    def state(self) -> CameraState: ...
