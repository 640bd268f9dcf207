"""What a simulated camera sees: flat targets (a printed board, a tag, a part's top face)
rendered through a pinhole camera with OpenCV's distortion model, by tracing each pixel's
ray back to the targets (so the image obeys exactly the model a calibration estimates).

Frames: a target's texture has its origin at the image's top-left corner, x along its
columns, y along its rows, z into the printed face (OpenCV's board frame); the camera's is
OpenCV's (x right, y down, z forward). Poses are 4×4 transforms into the world."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Gray = npt.NDArray[np.uint8]
Pixels = npt.NDArray[Any]  # OpenCV's images, of whatever depth
BACKGROUND = 96  # a grey table under everything
SUPERSAMPLING = 2  # rays per pixel along each axis: edges anti-aliased as a sensor would


@dataclass(frozen=True)
class CameraModel:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = ()  # k1, k2, p1, p2, k3 (OpenCV's order)
    pose: FloatArray = field(default_factory=lambda: np.eye(4))  # camera → world

    @property
    def matrix(self) -> FloatArray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def coefficients(self) -> FloatArray:
        """OpenCV takes 4, 5, 8, 12 or 14 coefficients: the ones given, zeros after."""
        size = next(n for n in (4, 5, 8, 12, 14) if n >= len(self.distortion))
        return np.array([*self.distortion, *[0.0] * (size - len(self.distortion))])


@dataclass(frozen=True)
class Target:
    """A flat printed thing: its texture, its size in metres, where it lies."""

    texture: Gray
    width: float  # m, along the texture's columns
    height: float  # m, along its rows
    pose: FloatArray  # target → world


class Renderer:
    """Renders scenes through one camera model; the rays of its pixels are found once."""

    def __init__(self, camera: CameraModel) -> None:
        self.camera = camera
        self.rays = pixel_rays(camera, SUPERSAMPLING)  # (h·s, w·s, 3) in the camera frame

    def render(
        self,
        targets: list[Target],
        *,
        noise: float = 0.0,
        blur: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> Gray:
        """The grey image: `noise` is the sensor's (standard deviation in grey levels),
        `blur` a Gaussian's sigma in pixels (focus)."""
        rows, cols = self.rays.shape[:2]
        image: Pixels = np.full((rows, cols), float(BACKGROUND), dtype=np.float32)
        nearest = np.full((rows, cols), np.inf, dtype=np.float32)
        camera_to_world = self.camera.pose
        for target in targets:
            window = self._window(target)
            if window is None:
                continue
            top, bottom, left, right = window
            rays = self.rays[top:bottom, left:right]
            world_to_target = np.linalg.inv(target.pose)
            to_target = world_to_target @ camera_to_world
            rotation, origin = to_target[:3, :3], to_target[:3, 3]
            if origin[2] >= 0:
                continue  # the camera is behind its print: only the blank back faces it
            directions = rays @ rotation.T  # each ray in the target's frame
            dz = directions[..., 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                distance = -origin[2] / dz  # along the ray to the plane z = 0
            x = origin[0] + distance * directions[..., 0]
            y = origin[1] + distance * directions[..., 1]
            texture_rows, texture_cols = target.texture.shape
            u = (x / target.width * texture_cols - 0.5).astype(np.float32)
            v = (y / target.height * texture_rows - 0.5).astype(np.float32)
            closer = nearest[top:bottom, left:right]
            inside = (
                (distance > 0)
                & (x >= 0)
                & (x < target.width)
                & (y >= 0)
                & (y < target.height)
                & (distance < closer)
            )
            seen = cv2.remap(
                _prefiltered(target.texture, u, v, inside),
                u,
                v,
                interpolation=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_REPLICATE,
            )
            image[top:bottom, left:right][inside] = seen[inside]
            closer[inside] = distance[inside]
        image = cv2.resize(
            image, (self.camera.width, self.camera.height), interpolation=cv2.INTER_AREA
        )
        if blur > 0:
            image = cv2.GaussianBlur(image, (0, 0), blur)
        if noise > 0:
            image = image + (rng or np.random.default_rng()).normal(0.0, noise, image.shape)
        return np.clip(np.rint(image), 0, 255).astype(np.uint8)

    def _window(self, target: Target) -> tuple[int, int, int, int] | None:
        """The rows and columns of the ray table a target can cover (all of it when a corner
        lies behind the camera); None when it is out of view."""
        rows, cols = self.rays.shape[:2]
        corners = np.array(
            [[0, 0, 0, 1], [target.width, 0, 0, 1], [0, target.height, 0, 1]], dtype=float
        )
        corners = np.vstack([corners, corners[1] + corners[2] - corners[0]])
        in_camera = (np.linalg.inv(self.camera.pose) @ target.pose @ corners.T)[:3].T
        if (in_camera[:, 2] <= 1e-6).any():
            return 0, rows, 0, cols
        # Projected without distortion, widened: distortion moves a point by far less than
        # the margin near the target, and a ray outside the window cannot reach it anyway
        # unless distortion is extreme, hence the generous margin.
        at = in_camera[:, :2] / in_camera[:, 2:3]
        us = at[:, 0] * self.camera.fx + self.camera.cx
        vs = at[:, 1] * self.camera.fy + self.camera.cy
        margin = 0.15 * max(self.camera.width, self.camera.height)
        s = SUPERSAMPLING
        left = int(max((us.min() - margin) * s, 0))
        right = int(min((us.max() + margin) * s, cols))
        top = int(max((vs.min() - margin) * s, 0))
        bottom = int(min((vs.max() + margin) * s, rows))
        if left >= right or top >= bottom:
            return None
        return top, bottom, left, right


def _prefiltered(texture: Gray, u: Pixels, v: Pixels, inside: Pixels) -> Pixels:
    """The texture blurred to the spacing of the rays that sample it (a mip level, once per
    target): sampled bare, an edge between two rays would land on one of them and a corner
    be found a quarter pixel off."""
    flat = texture.astype(np.float32)
    if not inside.any():
        return flat
    step = np.hypot(np.diff(u, axis=1), np.diff(v, axis=1))[inside[:, 1:] & inside[:, :-1]]
    if step.size == 0:
        return flat
    sigma = 1.0 * float(np.median(step))  # texels between two neighbouring rays
    return cv2.GaussianBlur(flat, (0, 0), sigma) if sigma > 0.3 else flat


def pixel_rays(camera: CameraModel, supersampling: int = 1) -> FloatArray:
    """For each (sub)pixel, the direction (x, y, 1) in the camera frame whose projection,
    distortion included, falls on its centre."""
    s = supersampling
    # Sub-pixel centres: pixel u spans [u - 0.5, u + 0.5].
    us = (np.arange(camera.width * s) + 0.5) / s - 0.5
    vs = (np.arange(camera.height * s) + 0.5) / s - 0.5
    grid = np.stack(np.meshgrid(us, vs), axis=-1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
    # R and P the identity: normalized coordinates out.
    normalized = cv2.undistortPointsIter(
        grid, camera.matrix, camera.coefficients, np.eye(3), np.eye(3), criteria
    ).reshape(camera.height * s, camera.width * s, 2)
    ones = np.ones((*normalized.shape[:2], 1))
    return np.concatenate([normalized.astype(float), ones], axis=-1)


def look_at(eye: FloatArray, target: FloatArray, up: FloatArray) -> FloatArray:
    """A camera pose (camera → world) at `eye` looking at `target`, image rows down
    along -`up` as far as the view allows."""
    forward = target - eye
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, up)
    right = right / np.linalg.norm(right)
    down = np.cross(forward, right)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, down, forward, eye
    return pose
