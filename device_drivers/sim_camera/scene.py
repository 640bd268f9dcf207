"""The simulated cell as a camera sees it: each part's top face (white, with its ArUco tag
printed in the middle) and the tag on the robot's flange, as flat targets in the world.

A tag is printed so that OpenCV's marker frame (centre, x right, y up the print, z out of
it) is the part's frame moved up to its top face: a detected tag's pose is where the part's
top face is. The cell's scene comes from the robot's simulator (`sim_cell`), in the world."""

from __future__ import annotations

from functools import cache
from typing import Any

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.optics import FloatArray, Gray, Target
from openpendant.runtime.imaging.boards import DICTIONARIES, dictionary_size

PIXELS_PER_METRE = 4000.0
TAG_SHARE = 0.8  # of a part's top face's shorter side: the marker, its black border included
QUIET_ZONE = 0.25  # white around a flange tag, as a share of its side (each way)
# The print's frame (x right, y down, z into it) in the part's frame: upside down about x.
FACE_UP = np.diag([1.0, -1.0, -1.0])


def matrix(pose: dict[str, Any]) -> FloatArray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(pose["orientation"]).as_matrix()
    m[:3, 3] = pose["position"]
    return m


@cache
def _marker(dictionary: str, marker_id: int, side: int) -> Gray:
    aruco = cv2.aruco.getPredefinedDictionary(DICTIONARIES[dictionary])
    return np.asarray(cv2.aruco.generateImageMarker(aruco, marker_id, side, borderBits=1))


@cache
def face_texture(dictionary: str, width: float, height: float, tag: int | None) -> Gray:
    """A part's top face: white, its tag (if any) in the middle."""
    cols, rows = round(width * PIXELS_PER_METRE), round(height * PIXELS_PER_METRE)
    face = np.full((rows, cols), 255, np.uint8)
    if tag is not None:
        side = round(TAG_SHARE * min(width, height) * PIXELS_PER_METRE)
        top, left = (rows - side) // 2, (cols - side) // 2
        face[top : top + side, left : left + side] = _marker(dictionary, tag, side)
    return face


@cache
def tag_texture(dictionary: str, size: float, tag: int) -> Gray:
    """A tag with its white quiet zone round it."""
    side = round(size * PIXELS_PER_METRE)
    border = round(QUIET_ZONE * side)
    return np.asarray(
        cv2.copyMakeBorder(
            _marker(dictionary, tag, side),
            border,
            border,
            border,
            border,
            cv2.BORDER_CONSTANT,
            value=255,
        )
    )


def part_target(part: dict[str, Any], dictionary: str) -> Target:
    sx, sy, sz = part["size"]
    tag = part.get("tag")
    if tag is not None and tag >= dictionary_size(dictionary):
        tag = None  # not a marker of this dictionary: a blank face
    corner = np.eye(4)
    corner[:3, :3] = FACE_UP
    corner[:3, 3] = [-sx / 2, sy / 2, sz / 2]  # the print's top-left corner, on top
    return Target(face_texture(dictionary, sx, sy, tag), sx, sy, matrix(part["pose"]) @ corner)


def flange_target(tag: dict[str, Any], dictionary: str) -> Target:
    """`tag["pose"]` is the tag's centre in the print's frame."""
    size = tag["size"] * (1 + 2 * QUIET_ZONE)
    corner = np.eye(4)
    corner[:3, 3] = [-size / 2, -size / 2, 0.0]
    texture = tag_texture(dictionary, tag["size"], tag["id"])
    return Target(texture, size, size, matrix(tag["pose"]) @ corner)


def cell_targets(scene: dict[str, Any], dictionary: str) -> list[Target]:
    targets = [part_target(part, dictionary) for part in scene.get("parts", [])]
    tag = scene.get("flange_tag")
    if tag is not None and tag["id"] < dictionary_size(dictionary):
        targets.append(flange_target(tag, dictionary))
    return targets
