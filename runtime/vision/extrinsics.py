"""Where a calibrated camera stands in the world, from a board lying at a known pose: each
frame gives the board in the camera (PnP), and the camera in the world is the board's world
pose times its inverse; the frames' estimates are averaged and their spread reported."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.runtime.imaging.boards import BoardView
from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.kit.errors import InvalidValue


def camera_matrix(k: Intrinsics) -> np.ndarray:
    return np.array([[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class PlanePose:
    """A board's pose in the camera and the RMS distance (px) of its corners from where
    that pose projects them."""

    matrix: np.ndarray  # 4×4, board in camera
    error: float


def board_in_camera(view: BoardView, k: Intrinsics) -> PlanePose:
    matrix, coefficients = camera_matrix(k), np.array(k.distortion, dtype=float)
    ok, rvec, tvec = cv2.solvePnP(
        view.board_points, view.image_points, matrix, coefficients, flags=cv2.SOLVEPNP_IPPE
    )
    if not ok:
        raise InvalidValue("the board's pose could not be found in this frame")
    rvec, tvec = cv2.solvePnPRefineLM(
        view.board_points, view.image_points, matrix, coefficients, rvec, tvec
    )
    projected, _ = cv2.projectPoints(view.board_points, rvec, tvec, matrix, coefficients)
    error = float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - view.image_points) ** 2, 1))))
    pose = np.eye(4)
    pose[:3, :3] = cv2.Rodrigues(rvec)[0]
    pose[:3, 3] = tvec.ravel()
    return PlanePose(pose, error)


@dataclass(frozen=True)
class Averaged:
    matrix: np.ndarray  # 4×4
    spread_m: float  # the largest distance of one estimate from the mean
    spread_deg: float


def average(poses: list[np.ndarray]) -> Averaged:
    """The mean of rigid poses (positions averaged, rotations by their chordal mean)."""
    positions = np.array([p[:3, 3] for p in poses])
    rotations = Rotation.from_matrix(np.array([p[:3, :3] for p in poses]))
    mean_rotation = rotations.mean()
    mean = np.eye(4)
    mean[:3, :3] = mean_rotation.as_matrix()
    mean[:3, 3] = positions.mean(axis=0)
    spread_m = float(np.linalg.norm(positions - mean[:3, 3], axis=1).max())
    spread_deg = float(np.degrees((rotations * mean_rotation.inv()).magnitude()).max())
    return Averaged(mean, spread_m, spread_deg)


def camera_in_world(board_in_world: np.ndarray, board_in_cam: np.ndarray) -> np.ndarray:
    return board_in_world @ np.linalg.inv(board_in_cam)
