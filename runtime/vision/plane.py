"""Where a pixel lies on a horizontal plane of the world (a table, a part's top face): its
ray from a calibrated, placed camera meets the plane; and a pose there, turned about z."""

from __future__ import annotations

import cv2
import numpy as np

from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.vision.extrinsics import camera_matrix
from openpendant.runtime.vision.transforms import pose_of


def on_plane(
    pixel: np.ndarray, intrinsics: Intrinsics, camera: np.ndarray, height: float
) -> np.ndarray | None:
    """The world point at `pixel` on the plane z = height (None: the ray misses it)."""
    normalized = cv2.undistortPoints(
        np.asarray(pixel, dtype=float).reshape(1, 1, 2),
        camera_matrix(intrinsics),
        np.array(intrinsics.distortion, dtype=float),
    ).ravel()
    ray = camera[:3, :3] @ np.array([normalized[0], normalized[1], 1.0])
    origin = camera[:3, 3]
    if abs(ray[2]) < 1e-9:
        return None
    distance = (height - origin[2]) / ray[2]
    return None if distance <= 0 else origin + distance * ray


def pose_on_plane(centre: np.ndarray, x_axis: np.ndarray, camera: np.ndarray) -> Pose:
    """In the camera frame: at `centre` (world), z up out of the plane, x along `x_axis`
    (world, projected onto the plane)."""
    x = np.array([x_axis[0], x_axis[1], 0.0])
    x /= np.linalg.norm(x)
    z = np.array([0.0, 0.0, 1.0])
    world = np.eye(4)
    world[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    world[:3, 3] = centre
    return pose_of(np.linalg.inv(camera) @ world)
