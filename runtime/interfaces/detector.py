"""The standard object detector: finds objects in a camera's image, each with its class or
marker id, confidence, box in the image and, where it can tell, its pose in the camera
frame."""

from __future__ import annotations

from abc import ABC, abstractmethod

from pydantic import BaseModel, Field

from openpendant.runtime.interfaces.common import Pose, Strict
from openpendant.runtime.interfaces.device import DeviceIdentity, KindDriver
from openpendant.runtime.interfaces.endpoints import endpoint


class DetectorInfo(BaseModel):
    model: str
    method: str = ""  # "aruco", "template", "neural", …
    classes: list[str] = Field(default_factory=list)  # what it can find (empty: open set)
    camera: str | None = None  # the camera (local name) it looks through, if fixed


class DetectorDescription(BaseModel):
    identity: DeviceIdentity
    info: DetectorInfo


class DetectorState(BaseModel):
    seqno: int
    ts: float
    connected: bool
    last_detection: float | None = None
    error: str = ""


class Box(BaseModel):
    """In image pixels: top-left corner and size."""

    x: float
    y: float
    width: float = Field(ge=0)
    height: float = Field(ge=0)


class Detection(BaseModel):
    label: str  # the class, or the marker's id
    confidence: float = Field(ge=0, le=1)
    box: Box
    pose: Pose | None = None  # in the camera frame, where the detector can tell


class DetectRequest(Strict):
    labels: list[str] | None = Field(default=None, max_length=256)  # only these
    min_confidence: float = Field(default=0.0, ge=0, le=1)


class Detections(BaseModel):
    """What one image showed; `ts` is when that image was taken."""

    ts: float
    camera: str | None = None
    width: int
    height: int
    detections: list[Detection]


class Detector(ABC):
    @endpoint("POST", "/detect", body=DetectRequest, returns=Detections)
    @abstractmethod
    async def detect(self, request: DetectRequest) -> Detections:
        """Detect in a new image."""


class DetectorDriver(KindDriver[DetectorInfo], Detector):
    description = DetectorDescription

    @abstractmethod
    def state(self) -> DetectorState: ...
