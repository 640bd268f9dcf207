"""Poses for a robot-origin calibration: flange poses spread over a region the user sets
(in the robot's base frame), each turning the flange tag towards the camera, tilted each
way within a range, and spun about its axis: the rotations a hand-eye solve needs."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.runtime.vision.models import PoseRegion


def _halton(index: int, base: int) -> float:
    result, f = 0.0, 1.0
    while index > 0:
        f /= base
        result += f * (index % base)
        index //= base
    return result


def flange_poses(
    region: PoseRegion, camera: np.ndarray, count: int, seed: int = 0
) -> list[np.ndarray]:
    """`count` flange poses (4x4, base frame) whose z looks at `camera` (its position in the
    base frame) within the region's tilt."""
    rng = np.random.default_rng(seed)
    centre, size = np.array(region.centre), np.array(region.size)
    poses = []
    for index in range(1, count + 1):
        # A Halton sequence spreads the positions evenly through the box.
        share = np.array([_halton(index, b) for b in (2, 3, 5)])
        position = centre + (share - 0.5) * size
        facing = camera - position
        facing /= np.linalg.norm(facing)
        across = np.cross(facing, rng.normal(size=3))
        across /= np.linalg.norm(across)
        tilt = np.radians(rng.uniform(0.4, 1.0) * region.tilt)
        z = Rotation.from_rotvec(across * tilt).apply(facing)
        reference = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(reference, z)
        x /= np.linalg.norm(x)
        frame = np.column_stack([x, np.cross(z, x), z])
        spin = Rotation.from_rotvec(z * np.radians(rng.uniform(-1, 1) * region.spin))
        pose = np.eye(4)
        pose[:3, :3] = spin.as_matrix() @ frame
        pose[:3, 3] = position
        poses.append(pose)
    return poses
