"""Detectors behind the standard detector interface, configured by a stored `detector`
variable (`detectors.<name>`): which camera they look through and how they find things.

ArUco: each marker of the dictionary is a detection labelled with its id, its 6-DoF pose in
the camera frame from its printed size (OpenCV's marker frame: centre, x right, y up the
print, z out of it) once the camera is calibrated."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Literal

import cv2
import numpy as np
from pydantic import Field, field_validator, model_validator

from openpendant.runtime.imaging.boards import Dictionary
from openpendant.runtime.imaging.markers import find_markers
from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.interfaces.common import Pose, Strict
from openpendant.runtime.interfaces.detector import (
    Box,
    Detection,
    Detections,
    DetectorInfo,
    DetectRequest,
)
from openpendant.runtime.interfaces.detector import Detector as DetectorInterface
from openpendant.runtime.vision.extrinsics import camera_matrix
from openpendant.runtime.vision.models import NAME
from openpendant.runtime.vision.robot_origin import tag_corners
from openpendant.runtime.vision.transforms import pose_of

Grab = Callable[[], Awaitable[tuple[np.ndarray, float]]]
MAX_TEMPLATE_BASE64 = 700_000  # a 512 KB PNG


def detector_variable(name: str) -> str:
    return f"detectors.{name}"


MODEL_FILE = r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,63}\.onnx$"  # a network in the models folder


class TemplateRegion(Strict):
    """Where in the image to look (px): the rest is not searched."""

    x: int = Field(ge=0, le=20000)
    y: int = Field(ge=0, le=20000)
    width: int = Field(ge=8, le=20000)
    height: int = Field(ge=8, le=20000)


class DetectorConfig(Strict):
    """A detector as the user set it up (the variable type `detector`): ArUco markers of a
    dictionary and printed size, a taught template (a PNG, base64) found turned by any
    angle and within a range of scales, or a neural network (a YOLO-style ONNX model the
    user put in the data directory's `models/`). A template's or a network's detections are
    placed in the world on the plane z = `height`."""

    method: Literal["aruco", "template", "neural"] = "aruco"
    camera: str = Field(pattern=NAME)
    # ArUco
    dictionary: Dictionary = "4x4_50"
    marker_size: float = Field(default=0.032, gt=0.001, le=1.0)  # m, the black square's side
    # Template
    template: str | None = Field(default=None, max_length=MAX_TEMPLATE_BASE64)
    label: str = Field(default="part", min_length=1, max_length=32)
    region: TemplateRegion | None = None
    angle_step: float = Field(default=10.0, ge=1.0, le=90.0)
    scales: tuple[float, float, float] = (0.9, 1.1, 0.1)  # lowest, highest, step
    threshold: float = Field(default=0.75, gt=0.0, le=1.0)
    max_matches: int = Field(default=10, ge=1, le=100)
    height: float = Field(default=0.0, ge=-10, le=10)  # m: the matched face's z in the world
    # Neural
    model: str | None = Field(default=None, pattern=MODEL_FILE)
    classes: list[str] = Field(default_factory=list, max_length=1000)
    layout: Literal["yolov5", "yolov8"] = "yolov8"
    input_size: int = Field(default=640, ge=32, le=2048, multiple_of=32)
    iou: float = Field(default=0.45, gt=0.0, le=1.0)  # overlap over which the weaker box goes

    @field_validator("scales")
    @classmethod
    def _range(cls, scales: tuple[float, float, float]) -> tuple[float, float, float]:
        low, high, step = scales
        if not 0.2 <= low <= high <= 5.0 or not 0 <= step <= 1 or (step == 0 and low != high):
            raise ValueError("scales are (lowest, highest, step), between 0.2 and 5")
        if step > 0 and (high - low) / step > 20:
            raise ValueError("at most 20 scale steps")
        return scales

    @model_validator(mode="after")
    def _taught(self) -> DetectorConfig:
        if self.method == "template" and self.template is None:
            raise ValueError("a template detector needs its template: teach one")
        if self.method == "neural" and self.model is None:
            raise ValueError("a neural detector needs its model: the name of an .onnx file")
        return self


class TemplateTeaching(Strict):
    """A template taught from the camera's image: the box drawn on it (px), and the
    detector's settings to change with it."""

    camera: str = Field(pattern=NAME)
    box: TemplateRegion
    label: str | None = Field(default=None, min_length=1, max_length=32)
    height: float | None = Field(default=None, ge=-10, le=10)
    region: TemplateRegion | None = None


class ArucoDetector(DetectorInterface):
    def __init__(self, config: DetectorConfig, grab: Grab, intrinsics: Intrinsics | None) -> None:
        self.config, self.grab, self.intrinsics = config, grab, intrinsics
        self.info = DetectorInfo(model="ArUco markers", method="aruco", camera=config.camera)

    async def detect(self, request: DetectRequest) -> Detections:
        gray, taken = await self.grab()
        found = await asyncio.to_thread(self.markers, gray)
        wanted = set(request.labels) if request.labels is not None else None
        detections = [d for d in found if wanted is None or d.label in wanted]
        height, width = gray.shape[:2]
        return Detections(
            ts=taken, camera=self.config.camera, width=width, height=height, detections=detections
        )

    def markers(self, gray: np.ndarray) -> list[Detection]:
        found = []
        for marker_id, corners in sorted(find_markers(gray, self.config.dictionary).items()):
            low, high = corners.min(axis=0), corners.max(axis=0)
            box = Box(x=low[0], y=low[1], width=high[0] - low[0], height=high[1] - low[1])
            pose = self._pose(corners) if self.intrinsics is not None else None
            found.append(Detection(label=str(marker_id), confidence=1.0, box=box, pose=pose))
        return found

    def _pose(self, corners: np.ndarray) -> Pose | None:
        assert self.intrinsics is not None
        ok, rvec, tvec = cv2.solvePnP(
            tag_corners(self.config.marker_size),
            corners,
            camera_matrix(self.intrinsics),
            np.array(self.intrinsics.distortion, dtype=float),
            flags=cv2.SOLVEPNP_IPPE_SQUARE,
        )
        if not ok:
            return None
        matrix = np.eye(4)
        matrix[:3, :3] = cv2.Rodrigues(rvec)[0]
        matrix[:3, 3] = tvec.ravel()
        return pose_of(matrix)
