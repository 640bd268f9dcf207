"""A camera calibration as OpenCV's YAML (the layout OpenCV's calibration sample writes and
reads: `camera_matrix`, `distortion_coefficients`, `image_width`, `image_height`,
`avg_reprojection_error`), written with cv2.FileStorage itself."""

from __future__ import annotations

import time
from typing import Any, cast

import cv2
import numpy as np
import yaml

from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.kit.bounded_yaml import load_yaml, loader_with
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.vision.models import CameraCalibration

MAX_FILE = 256 * 1024


def to_yaml(calibration: CameraCalibration) -> str:
    k = calibration.intrinsics
    storage = cv2.FileStorage("calibration.yaml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    storage.write("calibration_time", time.strftime("%c", time.gmtime(calibration.calibrated)))
    storage.write("camera_name", calibration.camera)
    storage.write("image_width", k.width)
    storage.write("image_height", k.height)
    matrix = np.array([[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]])
    storage.write("camera_matrix", matrix)
    storage.write("distortion_coefficients", np.array(k.distortion, dtype=float).reshape(-1, 1))
    storage.write("avg_reprojection_error", calibration.rms)
    if calibration.frame_errors:
        errors = np.array(calibration.frame_errors, dtype=float).reshape(-1, 1)
        storage.write("per_view_reprojection_errors", errors)
    return str(storage.releaseAndGetString())


def _matrix(loader: yaml.SafeLoader, node: yaml.Node) -> np.ndarray:
    fields = loader.construct_mapping(cast(yaml.MappingNode, node), deep=True)
    try:
        rows, cols, data = int(fields["rows"]), int(fields["cols"]), fields["data"]
        values = np.array([float(v) for v in data], dtype=float)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidValue(f"a matrix in the file is malformed ({exc})", code="bad_file") from None
    if values.size != rows * cols:
        raise InvalidValue("a matrix in the file has the wrong number of values", code="bad_file")
    return values.reshape(rows, cols)


# The safe loader, knowing OpenCV's matrix tag (the file is untrusted input: it is parsed in
# Python, within bounds, not by OpenCV's C++ reader).
_LOADER = loader_with({"tag:yaml.org,2002:opencv-matrix": _matrix})


def _read(text: str) -> dict[str, Any]:
    if len(text) > MAX_FILE:
        raise InvalidValue("a calibration file is a few kilobytes, not this", code="too_large")
    lines = text.lstrip().splitlines()
    if lines and lines[0].startswith("%YAML:"):  # OpenCV's header, not YAML's
        lines = lines[1:]
    try:
        data = load_yaml("\n".join(lines), _LOADER)
    except yaml.YAMLError as exc:
        raise InvalidValue(f"not a YAML file: {exc}", code="bad_file") from None
    if not isinstance(data, dict):
        raise InvalidValue("not an OpenCV calibration file", code="bad_file")
    return data


def _number(data: dict[str, Any], key: str) -> float:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidValue(f"the file needs a number {key}", code="bad_file")
    return float(value)


def from_yaml(text: str, camera: str) -> CameraCalibration:
    """A calibration from OpenCV's YAML; anything missing or malformed is a clear error."""
    data = _read(text)
    matrix, distortion = data.get("camera_matrix"), data.get("distortion_coefficients")
    width, height = _number(data, "image_width"), _number(data, "image_height")
    rms = _number(data, "avg_reprojection_error") if "avg_reprojection_error" in data else 0.0
    if not isinstance(matrix, np.ndarray) or matrix.shape != (3, 3):
        raise InvalidValue("the file has no 3x3 camera_matrix", code="bad_file")
    if not isinstance(distortion, np.ndarray) or distortion.size not in (4, 5, 8, 12, 14):
        raise InvalidValue(
            "the file's distortion_coefficients must be 4, 5, 8, 12 or 14 numbers",
            code="bad_file",
        )
    numbers = np.concatenate([matrix.ravel(), distortion.ravel(), [width, height, rms]])
    if not np.all(np.isfinite(numbers)):
        raise InvalidValue("the file holds a number that is not finite", code="bad_file")
    if width < 1 or height < 1 or width != int(width) or height != int(height):
        raise InvalidValue("the file's image_width and image_height are not sizes", code="bad_file")
    try:
        intrinsics = Intrinsics(
            width=int(width),
            height=int(height),
            fx=float(matrix[0, 0]),
            fy=float(matrix[1, 1]),
            cx=float(matrix[0, 2]),
            cy=float(matrix[1, 2]),
            distortion=[float(v) for v in distortion.ravel()],
        )
    except ValueError as exc:
        raise InvalidValue(
            f"the file's camera matrix is not a camera's: {exc}", code="bad_file"
        ) from None
    return CameraCalibration(
        camera=camera, intrinsics=intrinsics, rms=max(float(rms), 0.0), calibrated=time.time()
    )
