"""Detecting with a stored detector: the detections in the camera frame (once the camera is
calibrated) and in the world (once it is placed), with the age of the image they came from."""

from __future__ import annotations

import base64
import time
from pathlib import Path

import cv2
import numpy as np

from openpendant.runtime.interfaces.detector import DetectRequest
from openpendant.runtime.kit.errors import Conflict, InvalidValue, NotFound
from openpendant.runtime.variable_storage.client import StorageClient
from openpendant.runtime.vision.calibrations import Calibrations
from openpendant.runtime.vision.detectors import (
    ArucoDetector,
    DetectorConfig,
    TemplateTeaching,
    detector_variable,
)
from openpendant.runtime.vision.models import Located, LocatedDetections
from openpendant.runtime.vision.neural_detector import NeuralDetector
from openpendant.runtime.vision.template_detector import TemplateDetector
from openpendant.runtime.vision.transforms import matrix_of, pose_of


class Detection:
    def __init__(self, storage: StorageClient, calibrations: Calibrations, models: Path) -> None:
        self.storage, self.calibrations, self.models = storage, calibrations, models

    async def config(self, name: str) -> DetectorConfig:
        try:
            stored = await self.storage.get(detector_variable(name))
        except NotFound:
            raise NotFound(
                f"no detector {name!r}: set one up as the detector variable "
                f"{detector_variable(name)}",
                code="no_such_detector",
            ) from None
        return DetectorConfig.model_validate(stored.value)

    async def detect(self, name: str, request: DetectRequest) -> LocatedDetections:
        config = await self.config(name)
        try:
            intrinsics = (await self.calibrations.calibration(config.camera)).intrinsics
        except Conflict:
            intrinsics = None  # boxes only: a pose needs the camera's intrinsics
        camera = await self.calibrations.camera_pose(config.camera)

        async def grab() -> tuple[np.ndarray, float]:
            return await self.calibrations.grab(config.camera, colour=config.method == "neural")

        detector: ArucoDetector | TemplateDetector | NeuralDetector
        if config.method == "template":
            detector = TemplateDetector(config, grab, intrinsics, camera)
        elif config.method == "neural":
            detector = NeuralDetector(config, grab, self.models, intrinsics, camera)
        else:
            detector = ArucoDetector(config, grab, intrinsics)
        found = await detector.detect(request)
        located = [
            Located(
                **d.model_dump(),
                world_pose=None
                if d.pose is None or camera is None
                else pose_of(camera @ matrix_of(d.pose)),
            )
            for d in found.detections
            if d.confidence >= request.min_confidence
        ]
        return LocatedDetections(
            ts=found.ts,
            age=max(time.time() - found.ts, 0.0),
            detector=name,
            camera=config.camera,
            width=found.width,
            height=found.height,
            calibrated=intrinsics is not None,
            placed=intrinsics is not None and camera is not None,
            detections=located,
        )

    async def teach(self, name: str, request: TemplateTeaching) -> DetectorConfig:
        """A template cut from a new image of the camera (the box the user drew), stored as
        the detector `name` (its other settings kept if it already was one)."""
        gray, _ = await self.calibrations.grab(request.camera)
        box = request.box
        height, width = gray.shape[:2]
        if box.x + box.width > width or box.y + box.height > height:
            raise InvalidValue(
                f"the box reaches outside the {width}x{height} image", code="box_outside"
            )
        cut = gray[box.y : box.y + box.height, box.x : box.x + box.width]
        ok, png = cv2.imencode(".png", cut)
        if not ok:  # pragma: no cover - a crop of a decoded frame always encodes
            raise InvalidValue("the template could not be encoded")
        try:
            current = (await self.config(name)).model_dump()
        except NotFound:
            current = {}
        if current.get("method") != "template" or current.get("camera") != request.camera:
            current = {}
        fields = {
            **current,
            "method": "template",
            "camera": request.camera,
            "template": base64.b64encode(png.tobytes()).decode(),
            **request.model_dump(exclude={"camera", "box"}, exclude_none=True),
        }
        config = DetectorConfig.model_validate(fields)
        await self.storage.put(detector_variable(name), "detector", config.model_dump(mode="json"))
        return config
