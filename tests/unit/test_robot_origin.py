"""Robot-origin calibration's solve (issue 17): the base pose in the world from a flange tag's
corners seen at generated poses, with 0.2 px of noise on every corner, against the truth
the corners were made from; a pose that disagrees is flagged and left out."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.entry import SimCameraOptions, camera_model
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.vision.models import PoseRegion
from openpendant.runtime.vision.poses import flange_poses
from openpendant.runtime.vision.robot_origin import Camera, Sighting, solve_origin, tag_corners

MODEL = camera_model(SimCameraOptions())
CAMERA = Camera(MODEL.matrix, MODEL.coefficients, MODEL.pose)
SIZE = 0.06


def transform(rotation: Rotation, translation: list[float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation.as_matrix()
    m[:3, 3] = translation
    return m


BASE = transform(Rotation.from_euler("z", 2.0, degrees=True), [0.05, -0.02, 0.0])
TAG = transform(Rotation.from_euler("z", 10.0, degrees=True), [0.002, -0.001, 0.005])


def sightings(count: int, noise: float, seed: int = 3) -> list[Sighting]:
    rng = np.random.default_rng(seed)
    camera_in_base = (np.linalg.inv(BASE) @ MODEL.pose)[:3, 3]
    region = PoseRegion(centre=[0.45, 0.0, 0.45], size=[0.3, 0.3, 0.2])
    seen = []
    for flange in flange_poses(region, camera_in_base, count, seed):
        assert region.inside(flange[:3, 3])
        tag_to_camera = np.linalg.inv(MODEL.pose) @ BASE @ flange @ TAG
        rvec = cv2.Rodrigues(tag_to_camera[:3, :3])[0]
        at, _ = cv2.projectPoints(
            tag_corners(SIZE), rvec, tag_to_camera[:3, 3], CAMERA.matrix, CAMERA.distortion
        )
        corners = at.reshape(-1, 2) + rng.normal(0.0, noise, (4, 2))
        assert (corners > 0).all() and (corners < [MODEL.width, MODEL.height]).all()
        seen.append(Sighting(flange, corners))
    return seen


def off_by(found: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    mm = float(np.linalg.norm(found[:3, 3] - truth[:3, 3]) * 1000)
    turned = Rotation.from_matrix(found[:3, :3] @ truth[:3, :3].T).magnitude()
    return mm, float(np.degrees(turned))


def test_the_base_is_found_within_a_millimetre_and_a_tenth_of_a_degree() -> None:
    stages: list[str] = []
    found = solve_origin(sightings(15, 0.2), SIZE, CAMERA, lambda _p, s: stages.append(s))
    mm, degrees = off_by(found.base, BASE)
    assert mm < 1.0 and degrees < 0.1, (mm, degrees)
    assert off_by(found.tag, TAG)[0] < 1.0
    assert found.outliers == [] and found.rms_px < 0.4
    assert len(found.residuals_px) == len(found.residuals_mm) == 15
    assert stages[0] == "a first estimate"


def test_a_pose_whose_corners_disagree_is_flagged_and_left_out() -> None:
    seen = sightings(12, 0.2)
    bad = seen[5]
    seen[5] = Sighting(bad.flange, bad.corners + [6.0, -4.0])  # the arm had not settled
    found = solve_origin(seen, SIZE, CAMERA, lambda _p, _s: None)
    assert found.outliers == [5]
    assert found.residuals_px[5] > 3.0
    mm, degrees = off_by(found.base, BASE)
    assert mm < 1.0 and degrees < 0.1, (mm, degrees)


def test_too_few_poses_is_a_clear_error() -> None:
    with pytest.raises(InvalidValue, match="4 at least"):
        solve_origin(sightings(3, 0.2), SIZE, CAMERA, lambda _p, _s: None)
