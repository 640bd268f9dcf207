"""The neural detector: a YOLO-style ONNX model the user provides (in the data directory's
`models/`, nothing is downloaded), run with OpenCV's DNN module. Its boxes are decoded and
suppressed (runtime/imaging/yolo.py); where the camera is calibrated and placed, a box's
centre is placed on the plane z = `height` of the world (no turn: a box has none)."""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from openpendant.runtime.imaging.yolo import Found, decode, letterbox
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
from openpendant.runtime.kit.errors import InvalidValue, NotFound
from openpendant.runtime.vision.detectors import DetectorConfig, Grab
from openpendant.runtime.vision.plane import on_plane, pose_on_plane

_nets: dict[tuple[Path, float], Any] = {}
_lock = threading.Lock()  # a network runs one image at a time


def load(path: Path) -> Any:
    """The network from its file, read again only when the file changes."""
    try:
        changed = path.stat().st_mtime
    except FileNotFoundError:
        raise NotFound(
            f"no model {path.name}: put the .onnx file in {path.parent}", code="no_such_model"
        ) from None
    key = (path, changed)
    if key not in _nets:
        try:
            net = cv2.dnn.readNetFromONNX(str(path))
        except cv2.error as exc:
            raise InvalidValue(
                f"{path.name} is not a model OpenCV can run: {exc.msg.strip()[:200]}",
                code="bad_model",
            ) from None
        _nets.clear()  # one model's weights at a time in memory
        _nets[key] = net
    return _nets[key]


class NeuralDetector(DetectorInterface):
    def __init__(
        self,
        config: DetectorConfig,
        grab: Grab,
        models: Path,
        intrinsics: Intrinsics | None,
        camera: np.ndarray | None,
    ) -> None:
        assert config.model is not None
        self.config, self.grab = config, grab
        self.path = models / config.model
        self.intrinsics, self.camera = intrinsics, camera
        self.info = DetectorInfo(
            model=config.model, method="neural", classes=config.classes, camera=config.camera
        )

    async def detect(self, request: DetectRequest) -> Detections:
        image, taken = await self.grab()
        found = await asyncio.to_thread(self.run, image)
        detections = [self._detection(f) for f in found]
        if request.labels is not None:
            detections = [d for d in detections if d.label in request.labels]
        height, width = image.shape[:2]
        return Detections(
            ts=taken, camera=self.config.camera, width=width, height=height, detections=detections
        )

    def run(self, image: np.ndarray) -> list[Found]:
        colour = image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        size = self.config.input_size
        square, box = letterbox(colour, size)
        blob = cv2.dnn.blobFromImage(square, 1 / 255.0, (size, size), swapRB=True)
        with _lock:
            net = load(self.path)
            net.setInput(blob)
            try:
                output = np.asarray(net.forward())
            except cv2.error as exc:
                raise InvalidValue(
                    f"{self.config.model} did not run on a {size}x{size} input "
                    f"(is input_size the model's?): {exc.msg.strip()[:200]}",
                    code="bad_model",
                ) from None
        height, width = image.shape[:2]
        try:
            return decode(
                output,
                self.config.layout,
                box,
                confidence=self.config.threshold,
                iou=self.config.iou,
                image_size=(width, height),
            )
        except (ValueError, IndexError) as exc:
            raise InvalidValue(
                f"{self.config.model}'s output {output.shape} is not {self.config.layout}'s: {exc}",
                code="bad_model",
            ) from None

    def _detection(self, found: Found) -> Detection:
        classes = self.config.classes
        label = classes[found.cls] if found.cls < len(classes) else str(found.cls)
        box = Box(x=found.x, y=found.y, width=found.width, height=found.height)
        return Detection(
            label=label, confidence=min(max(found.score, 0.0), 1.0), box=box, pose=self._pose(found)
        )

    def _pose(self, found: Found) -> Pose | None:
        if self.intrinsics is None or self.camera is None:
            return None
        centre = np.array([found.x + found.width / 2, found.y + found.height / 2])
        at = on_plane(centre, self.intrinsics, self.camera, self.config.height)
        if at is None:
            return None
        return pose_on_plane(at, np.array([1.0, 0.0, 0.0]), self.camera)
