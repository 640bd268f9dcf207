"""Robot-origin calibration: where a robot's base stands in the world, from an ArUco tag on
its flange seen by a calibrated camera at several poses of the robot.

At pose i the tag's corners c (in the tag's frame) appear in the image at
project(K, D, camera⁻¹ · X · F_i · Y · c), where `camera` is the camera in the world
(its extrinsic calibration), F_i the flange in the base frame (the robot's kinematics), and
the unknowns X (the base in the world) and Y (the tag on the flange). A closed-form start
(OpenCV's robot-world/hand-eye solve on the tag's per-pose PnP poses) is refined by least
squares over every corner's reprojection error; poses that disagree are flagged and left
out."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.runtime.kit.errors import InvalidValue

MIN_POSES = 4
OUTLIER_FACTOR, OUTLIER_FLOOR = 3.0, 1.0  # a pose's RMS beyond both (px): left out
Progress = Callable[[float, str], None]


def tag_corners(size: float) -> np.ndarray:
    """OpenCV's marker corners (top-left, top-right, bottom-right, bottom-left) in the
    marker's frame: centre origin, x right, y up the print, z out of it."""
    h = size / 2
    return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], dtype=float)


@dataclass(frozen=True)
class Sighting:
    """One pose of the robot: its flange in the base frame and the tag's corners seen."""

    flange: np.ndarray  # 4x4
    corners: np.ndarray  # (4, 2) px


@dataclass(frozen=True)
class Camera:
    matrix: np.ndarray  # 3x3
    distortion: np.ndarray
    pose: np.ndarray  # 4x4, camera in the world


@dataclass(frozen=True)
class OriginSolution:
    base: np.ndarray  # 4x4, the robot's base in the world
    tag: np.ndarray  # 4x4, the tag on the flange
    residuals_px: list[float]  # per pose, RMS over its corners
    residuals_mm: list[float]  # per pose, the tag's centre: predicted against seen alone
    outliers: list[int]
    rms_px: float


def _matrix(params: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_rotvec(params[:3]).as_matrix()
    m[:3, 3] = params[3:6]
    return m


def _params(m: np.ndarray) -> np.ndarray:
    return np.concatenate([Rotation.from_matrix(m[:3, :3]).as_rotvec(), m[:3, 3]])


def _inverse(m: np.ndarray) -> np.ndarray:
    inv = np.eye(4)
    inv[:3, :3] = m[:3, :3].T
    inv[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return inv


def tag_in_camera(sighting: Sighting, size: float, camera: Camera) -> np.ndarray:
    ok, rvec, tvec = cv2.solvePnP(
        tag_corners(size),
        sighting.corners.astype(float),
        camera.matrix,
        camera.distortion,
        flags=cv2.SOLVEPNP_IPPE_SQUARE,
    )
    if not ok:
        raise InvalidValue("the tag's pose could not be found in a frame")
    m = np.eye(4)
    m[:3, :3] = cv2.Rodrigues(rvec)[0]
    m[:3, 3] = tvec.ravel()
    return m


def _start(sightings: list[Sighting], size: float, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """X and Y in closed form: with A_i = tag←camera and B_i = flange←base, OpenCV solves
    A_i · (camera←base) = (tag←flange) · B_i."""
    tags = [_inverse(tag_in_camera(s, size, camera)) for s in sightings]
    flanges = [_inverse(s.flange) for s in sightings]
    r_base, t_base, r_tag, t_tag = cv2.calibrateRobotWorldHandEye(
        [a[:3, :3] for a in tags],
        [a[:3, 3] for a in tags],
        [b[:3, :3] for b in flanges],
        [b[:3, 3] for b in flanges],
    )
    base_in_camera = np.eye(4)
    base_in_camera[:3, :3], base_in_camera[:3, 3] = r_base, np.ravel(t_base)
    tag_from_flange = np.eye(4)
    tag_from_flange[:3, :3], tag_from_flange[:3, 3] = r_tag, np.ravel(t_tag)
    return camera.pose @ base_in_camera, _inverse(tag_from_flange)


def _residuals(
    params: np.ndarray, sightings: list[Sighting], corners: np.ndarray, camera: Camera
) -> np.ndarray:
    base, tag = _matrix(params[:6]), _matrix(params[6:])
    world_to_camera = _inverse(camera.pose)
    errors = []
    for s in sightings:
        tag_to_camera = world_to_camera @ base @ s.flange @ tag
        rvec = cv2.Rodrigues(tag_to_camera[:3, :3])[0]
        at, _ = cv2.projectPoints(
            corners, rvec, tag_to_camera[:3, 3], camera.matrix, camera.distortion
        )
        errors.append((at.reshape(-1, 2) - s.corners).ravel())
    return np.concatenate(errors)


def _refine(
    sightings: list[Sighting], size: float, camera: Camera, base: np.ndarray, tag: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # Imported here, in the one process that solves: scipy.optimize is 65 MB of memory that
    # the launcher would otherwise preload and every runtime process would map.
    from scipy.optimize import least_squares

    corners = tag_corners(size)
    fit = least_squares(
        _residuals,
        np.concatenate([_params(base), _params(tag)]),
        args=(sightings, corners, camera),
        method="lm",
    )
    per_pose = np.sqrt(np.mean(fit.fun.reshape(len(sightings), -1) ** 2, axis=1))
    return _matrix(fit.x[:6]), _matrix(fit.x[6:]), per_pose


def solve_origin(
    sightings: list[Sighting], size: float, camera: Camera, progress: Progress
) -> OriginSolution:
    if len(sightings) < MIN_POSES:
        raise InvalidValue(
            f"the tag was seen at {len(sightings)} poses: {MIN_POSES} at least are needed",
            code="too_few_poses",
        )
    progress(0.1, "a first estimate")
    base, tag = _start(sightings, size, camera)
    progress(0.4, "refining over every corner")
    use = list(range(len(sightings)))
    base, tag, per_pose = _refine(sightings, size, camera, base, tag)
    limit = max(OUTLIER_FACTOR * float(np.median(per_pose)), OUTLIER_FLOOR)
    outliers = [i for i in use if per_pose[i] > limit]
    if outliers and len(use) - len(outliers) >= MIN_POSES:
        progress(0.7, f"refining again without {len(outliers)} poses that disagree")
        use = [i for i in use if i not in outliers]
        base, tag, _ = _refine([sightings[i] for i in use], size, camera, base, tag)
    else:
        outliers = []
    progress(0.9, "checking each pose")
    residuals = _residuals(
        np.concatenate([_params(base), _params(tag)]), sightings, tag_corners(size), camera
    ).reshape(len(sightings), -1)
    px = np.sqrt(np.mean(residuals**2, axis=1))
    mm = []
    for s in sightings:
        predicted = base @ s.flange @ tag
        seen = camera.pose @ tag_in_camera(s, size, camera)
        mm.append(float(np.linalg.norm(predicted[:3, 3] - seen[:3, 3]) * 1000))
    kept = np.array([px[i] for i in use])
    return OriginSolution(
        base=base,
        tag=tag,
        residuals_px=[float(v) for v in px],
        residuals_mm=mm,
        outliers=outliers,
        rms_px=float(np.sqrt(np.mean(kept**2))),
    )
