"""Finding ArUco markers in an image, their corners refined to a fraction of a pixel."""

from __future__ import annotations

from functools import cache
from typing import Any

import cv2
import numpy as np

from runtime.imaging.boards import DICTIONARIES


@cache
def _detector(dictionary: str) -> Any:
    parameters = cv2.aruco.DetectorParameters()
    parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    parameters.cornerRefinementMinAccuracy = 0.01
    aruco = cv2.aruco.getPredefinedDictionary(DICTIONARIES[dictionary])
    return cv2.aruco.ArucoDetector(aruco, parameters)


def find_markers(gray: np.ndarray, dictionary: str) -> dict[int, np.ndarray]:
    """Each marker seen, by id: its four corners (top-left, top-right, bottom-right,
    bottom-left of the print), (4, 2) pixels. A marker seen twice is left out: which one
    was meant cannot be told."""
    corners, ids, _ = _detector(dictionary).detectMarkers(gray)
    if ids is None:
        return {}
    found: dict[int, np.ndarray] = {}
    twice: set[int] = set()
    for marker_id, at in zip(ids.ravel().tolist(), corners, strict=True):
        if marker_id in found:
            twice.add(marker_id)
        found[marker_id] = np.asarray(at, dtype=float).reshape(4, 2)
    return {k: v for k, v in found.items() if k not in twice}
