"""Where to hold a calibration board in front of a camera, as a person doing a good
calibration would: over the whole image, near and far, tilted each way. From the camera's
model (a simulated camera's ground truth); poses are the board's in the camera frame, with
the board's frame at its printed top-left corner (x along columns, y down rows)."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

# Where the board's centre goes, as a share of the image's width and height.
SPOTS = (
    (0.5, 0.5),
    (0.2, 0.22),
    (0.8, 0.22),
    (0.2, 0.78),
    (0.8, 0.78),
    (0.5, 0.2),
    (0.5, 0.8),
    (0.2, 0.5),
    (0.8, 0.5),
)
TILTS = ((0, 0), (30, 0), (-30, 0), (0, 30), (0, -30), (20, 20), (-20, -20), (25, -20), (-25, 20))


def camera_arrays(model: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    matrix = np.array(
        [[model["fx"], 0, model["cx"]], [0, model["fy"], model["cy"]], [0, 0, 1]], dtype=float
    )
    return matrix, np.array(model["distortion"], dtype=float)


def board_views(
    model: dict[str, Any],
    size: tuple[float, float],
    count: int,
    margin: float = 0.04,
    fill: float = 0.55,
) -> list[np.ndarray]:
    """`count` poses of a board of `size` (m) that show it whole, spread over the image and
    its tilts: each no nearer than where it would span `fill` of the image's width, pulled
    back from there until it fits inside the image's margin."""
    matrix, coefficients = camera_arrays(model)
    width, height = model["width"], model["height"]
    corners = np.array(
        [[0, 0, 0], [size[0], 0, 0], [0, size[1], 0], [size[0], size[1], 0]], dtype=float
    )
    poses = []
    for index in range(count):
        u, v = SPOTS[index % len(SPOTS)]
        tilt_x, tilt_y = TILTS[(index * 4 + index // len(SPOTS)) % len(TILTS)]
        rotation = Rotation.from_euler("xy", [tilt_x, tilt_y], degrees=True).as_matrix()
        ray = np.linalg.inv(matrix) @ np.array([u * width, v * height, 1.0])
        nearest = size[0] * model["fx"] / (fill * width)
        for distance in nearest * np.arange(1.0, 8.0, 0.03):
            centre = ray / np.linalg.norm(ray) * distance
            pose = np.eye(4)
            pose[:3, :3] = rotation
            pose[:3, 3] = centre - rotation @ np.array([size[0] / 2, size[1] / 2, 0.0])
            seen = (pose[:3, :3] @ corners.T).T + pose[:3, 3]
            at, _ = cv2.projectPoints(seen, np.zeros(3), np.zeros(3), matrix, coefficients)
            at = at.reshape(-1, 2)
            inside = (
                (at[:, 0] > margin * width).all()
                and (at[:, 0] < (1 - margin) * width).all()
                and (at[:, 1] > margin * height).all()
                and (at[:, 1] < (1 - margin) * height).all()
            )
            if inside:
                poses.append(pose)
                break
    return poses


def in_world(camera_pose: np.ndarray, board_in_camera: np.ndarray) -> dict[str, list[float]]:
    """A board pose in the camera as the world pose the simulator takes."""
    pose = camera_pose @ board_in_camera
    return {
        "position": pose[:3, 3].tolist(),
        "orientation": Rotation.from_matrix(pose[:3, :3]).as_quat().tolist(),
    }
