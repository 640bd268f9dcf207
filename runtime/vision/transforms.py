"""Poses as the interfaces carry them and as 4x4 transforms."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.runtime.interfaces.common import Pose


def matrix_of(pose: Pose) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(pose.orientation).as_matrix()
    matrix[:3, 3] = pose.position
    return matrix


def pose_of(matrix: np.ndarray) -> Pose:
    quaternion = Rotation.from_matrix(matrix[:3, :3]).as_quat()
    return Pose(position=matrix[:3, 3].tolist(), orientation=quaternion.tolist())
