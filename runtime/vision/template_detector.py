"""The template detector: a taught pattern found turned and scaled in the camera's image.
Where the camera is calibrated and placed, each match is located on the plane of the
matched face (its height in the world, from the detector's setting): the pixel's ray meets
that plane, and the pattern's turn in the image becomes a turn about the world's z. The pose
follows the ArUco detector's convention: z out of the face, towards the camera; x along the
pattern's x as taught; y up the pattern."""

from __future__ import annotations

import asyncio
import base64

import cv2
import numpy as np

from openpendant.runtime.imaging.template import Match, find_template
from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.detector import (
    Box,
    Detection,
    Detections,
    DetectorInfo,
    DetectRequest,
)
from openpendant.runtime.interfaces.detector import Detector as DetectorInterface
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.vision.detectors import DetectorConfig, Grab
from openpendant.runtime.vision.plane import on_plane, pose_on_plane

REACH = 20.0  # px along the pattern's x to a second point, for its direction on the plane


def decode_template(data: str) -> np.ndarray:
    try:
        raw = np.frombuffer(base64.b64decode(data, validate=True), np.uint8)
    except ValueError:
        raise InvalidValue("the template is not base64", code="bad_template") from None
    image = cv2.imdecode(raw, cv2.IMREAD_GRAYSCALE)
    if image is None or min(image.shape[:2]) < 8:
        raise InvalidValue("the template is not a PNG of 8 px or more", code="bad_template")
    return np.asarray(image)


class TemplateDetector(DetectorInterface):
    def __init__(
        self,
        config: DetectorConfig,
        grab: Grab,
        intrinsics: Intrinsics | None,
        camera: np.ndarray | None,
    ) -> None:
        assert config.template is not None
        self.config, self.grab = config, grab
        self.intrinsics, self.camera = intrinsics, camera
        self.pattern = decode_template(config.template)
        self.info = DetectorInfo(
            model="template", method="template", classes=[config.label], camera=config.camera
        )

    async def detect(self, request: DetectRequest) -> Detections:
        gray, taken = await self.grab()
        matches = await asyncio.to_thread(self.find, gray)
        detections = [self._detection(m) for m in matches]
        if request.labels is not None:
            detections = [d for d in detections if d.label in request.labels]
        height, width = gray.shape[:2]
        return Detections(
            ts=taken, camera=self.config.camera, width=width, height=height, detections=detections
        )

    def find(self, gray: np.ndarray) -> list[Match]:
        left = top = 0
        region = self.config.region
        if region is not None:
            left, top = region.x, region.y
            gray = gray[top : top + region.height, left : left + region.width]
            if min(gray.shape[:2]) < min(self.pattern.shape[:2]):
                raise InvalidValue(
                    "the detector's region lies outside the camera's image or is smaller "
                    "than its template",
                    code="bad_region",
                )
        found = find_template(
            gray,
            self.pattern,
            angle_step=self.config.angle_step,
            scales=self.config.scales,
            threshold=self.config.threshold,
            max_matches=self.config.max_matches,
        )
        return [
            Match(m.x + left, m.y + top, m.angle, m.scale, m.score, m.width, m.height)
            for m in found
        ]

    def _detection(self, match: Match) -> Detection:
        box = Box(
            x=match.x - match.width / 2,
            y=match.y - match.height / 2,
            width=match.width,
            height=match.height,
        )
        return Detection(
            label=self.config.label,
            confidence=float(np.clip(match.score, 0.0, 1.0)),
            box=box,
            pose=self._pose(match),
        )

    def _pose(self, match: Match) -> Pose | None:
        """In the camera frame, from where the match lies on the face's plane in the world."""
        if self.intrinsics is None or self.camera is None:
            return None
        radians = np.radians(match.angle)
        ends = [
            on_plane(pixel, self.intrinsics, self.camera, self.config.height)
            for pixel in (
                np.array([match.x, match.y]),
                np.array([match.x + REACH * np.cos(radians), match.y - REACH * np.sin(radians)]),
            )
        ]
        centre, along = ends
        if centre is None or along is None:
            return None
        return pose_on_plane(centre, along - centre, self.camera)
