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
from pydantic import BaseModel, Field, field_validator

from runtime.imaging.boards import DICTIONARIES
from runtime.imaging.markers import find_markers
from runtime.interfaces.camera import Intrinsics
from runtime.interfaces.common import Pose, Strict
from runtime.interfaces.detector import (
    Box,
    Detection,
    Detections,
    DetectorInfo,
    DetectRequest,
)
from runtime.interfaces.detector import Detector as DetectorInterface
from runtime.vision.extrinsics import camera_matrix
from runtime.vision.models import NAME
from runtime.vision.robot_origin import tag_corners
from runtime.vision.transforms import pose_of

Grab = Callable[[], Awaitable[tuple[np.ndarray, float]]]


def detector_variable(name: str) -> str:
    return f"detectors.{name}"


class DetectorConfig(Strict):
    """A detector as the user set it up (the variable type `detector`)."""

    method: Literal["aruco"] = "aruco"
    camera: str = Field(pattern=NAME)
    dictionary: str = Field(default="4x4_50", max_length=32)
    marker_size: float = Field(default=0.032, gt=0.001, le=1.0)  # m, the black square's side

    @field_validator("dictionary")
    @classmethod
    def _known(cls, name: str) -> str:
        if name not in DICTIONARIES:
            raise ValueError(f"no ArUco dictionary {name!r} (e.g. 4x4_50, 5x5_100)")
        return name


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


class Located(Detection):
    """A detection with its pose in the world, where the camera is placed in it."""

    world_pose: Pose | None = None


class LocatedDetections(BaseModel):
    """What one image showed; `ts` is when it was taken and `age` how long before the answer
    (s): a program acting on a detection knows how old it is."""

    ts: float
    age: float
    detector: str
    camera: str
    width: int
    height: int
    calibrated: bool  # poses in the camera frame
    placed: bool  # and in the world
    detections: list[Located] = Field(default_factory=list)
