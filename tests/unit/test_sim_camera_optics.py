"""The simulated camera's optics (issue 17's first step): images rendered by tracing each
pixel's ray obey exactly the camera model a calibration estimates. Checked with OpenCV's
own detectors and solvers, against the model the images were made with."""

from __future__ import annotations

from typing import Any, cast

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.optics import (
    BACKGROUND,
    CameraModel,
    Renderer,
    Target,
    look_at,
)

CAMERA = CameraModel(640, 400, 450.0, 452.0, 322.5, 197.0, (-0.12, 0.06, 0.0005, -0.0003, 0.0))
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100)


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(CAMERA)


def board_pose(rng: np.random.Generator, width: float, height: float) -> np.ndarray:
    """The board's centre 0.3-0.5 m in front of the camera, tilted up to 40°."""
    angles = [rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-30, 30)]
    rotation = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
    centre = np.array([rng.uniform(-0.1, 0.1), rng.uniform(-0.06, 0.06), rng.uniform(0.3, 0.5)])
    pose = np.eye(4)
    pose[:3, :3] = rotation
    pose[:3, 3] = centre - rotation @ np.array([width / 2, height / 2, 0.0])
    return pose


def test_a_charuco_calibration_recovers_the_camera_it_was_rendered_with(
    renderer: Renderer,
) -> None:
    board = cv2.aruco.CharucoBoard((9, 6), 0.03, 0.022, DICTIONARY)
    width, height = 9 * 0.03, 6 * 0.03
    texture = np.asarray(board.generateImage((1800, 1200), marginSize=0), dtype=np.uint8)
    detector = cv2.aruco.CharucoDetector(board)
    rng = np.random.default_rng(17)
    objects, images = [], []
    for _ in range(12):
        pose = board_pose(rng, width, height)
        image = renderer.render([Target(texture, width, height, pose)], noise=2.0, rng=rng)
        corners, ids, _, _ = detector.detectBoard(image)
        assert ids is not None and len(ids) >= 30, "the board was not seen"
        seen, at = cast(Any, board).matchImagePoints(corners, ids)
        objects.append(seen)
        images.append(at)
    rms, matrix, distortion, _, _ = cv2.calibrateCamera(
        objects, images, (CAMERA.width, CAMERA.height), None, None
    )
    assert rms <= 0.3
    assert matrix[0, 0] == pytest.approx(CAMERA.fx, rel=0.005)
    assert matrix[1, 1] == pytest.approx(CAMERA.fy, rel=0.005)
    assert matrix[0, 2] == pytest.approx(CAMERA.cx, abs=2.0)
    assert matrix[1, 2] == pytest.approx(CAMERA.cy, abs=2.0)
    assert distortion.ravel()[0] == pytest.approx(CAMERA.distortion[0], abs=0.01)


def test_a_boards_corners_fall_where_the_model_projects_them(renderer: Renderer) -> None:
    """Independent of any calibration: the detected corners (saddle points, refined to a
    fraction of a pixel) against cv2.projectPoints of where they truly are."""
    board = cv2.aruco.CharucoBoard((9, 6), 0.03, 0.022, DICTIONARY)
    width, height = 9 * 0.03, 6 * 0.03
    texture = np.asarray(board.generateImage((1800, 1200), marginSize=0), dtype=np.uint8)
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("xy", [25, -15], degrees=True).as_matrix()
    pose[:3, 3] = [-0.15, -0.08, 0.38]
    image = renderer.render([Target(texture, width, height, pose)])
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(image)
    assert ids is not None and len(ids) >= 30
    truth = np.asarray(board.getChessboardCorners())[ids.ravel()]
    world = (pose[:3, :3] @ truth.T).T + pose[:3, 3]
    expected, _ = cv2.projectPoints(
        world, np.zeros(3), np.zeros(3), CAMERA.matrix, CAMERA.coefficients
    )
    offsets = corners.reshape(-1, 2) - expected.reshape(-1, 2)
    assert np.abs(offsets.mean(axis=0)).max() < 0.03  # no shift: pixel centres agree
    assert np.linalg.norm(offsets, axis=1).max() < 0.2  # 0.4 before the texture's prefilter


def test_the_nearer_target_hides_the_farther_and_nothing_behind_the_camera_shows(
    renderer: Renderer,
) -> None:
    black, white = np.zeros((10, 10), np.uint8), np.full((10, 10), 255, np.uint8)
    near, far, behind = np.eye(4), np.eye(4), np.eye(4)
    near[:3, 3] = [-0.5, -0.5, 1.0]
    far[:3, 3] = [-0.5, -0.5, 2.0]
    behind[:3, 3] = [-0.5, -0.5, -1.0]
    for order in ([near, far], [far, near]):
        targets = [Target(white if p is near else black, 1.0, 1.0, p) for p in order]
        image = renderer.render(targets)
        assert image[200, 320] == 255
    image = renderer.render([Target(white, 1.0, 1.0, behind)])
    assert (image == BACKGROUND).all()


def test_look_at_points_the_optical_axis_at_its_target() -> None:
    pose = look_at(np.array([0.5, -0.4, 1.2]), np.array([0.1, 0.2, 0.0]), np.array([0, 0, 1.0]))
    assert np.allclose(pose[:3, :3].T @ pose[:3, :3], np.eye(3))
    assert np.linalg.det(pose[:3, :3]) == pytest.approx(1.0)
    axis = np.array([0.1, 0.2, 0.0]) - pose[:3, 3]
    assert np.allclose(pose[:3, 2], axis / np.linalg.norm(axis))
    assert pose[2, 1] < 0  # image rows run downwards in the world
