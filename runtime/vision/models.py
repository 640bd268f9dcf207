"""What the vision service takes and gives: a camera's calibration as it is stored (the
variable type `camera_calibration`), a guided capture's progress, and long operations."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, Field

from openpendant.runtime.imaging.boards import BoardSpec, Dictionary
from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.interfaces.common import Pose, Strict, Vector3
from openpendant.runtime.interfaces.detector import Detection

NAME = r"^[a-z][a-z0-9_]{0,31}$"  # a device's local name


class PoseRegion(Strict):
    """A box in the robot's base frame (centre and size, m) and how far from facing the
    camera the tag may turn (degrees)."""

    centre: Vector3 = Field(default_factory=lambda: [0.4, 0.0, 0.4])
    size: Vector3 = Field(default_factory=lambda: [0.3, 0.3, 0.2])
    tilt: float = Field(default=30.0, ge=5.0, le=60.0)
    spin: float = Field(default=60.0, ge=0.0, le=180.0)

    def inside(self, point: np.ndarray) -> bool:
        lower = np.array(self.centre) - np.array(self.size) / 2
        return bool(np.all(point >= lower - 1e-9) and np.all(point <= lower + self.size))


def calibration_variable(camera: str) -> str:
    return f"calibration.{camera}"


class CameraCalibration(Strict):
    """A camera's intrinsics as a calibration found them, and how well: the RMS
    reprojection error (px), each parameter's standard deviation, each frame's error."""

    camera: str = Field(min_length=1, max_length=64)
    intrinsics: Intrinsics
    rms: float = Field(ge=0)
    uncertainty: dict[str, float] = Field(default_factory=dict, max_length=32)
    frame_errors: list[float] = Field(default_factory=list, max_length=1000)
    board: BoardSpec | None = None  # None: imported from a file
    calibrated: float = Field(ge=0)  # when (Unix time)


class Advice(BaseModel):
    """What to show the camera next, as a code a UI words in its language (and in English)."""

    code: Literal["start", "show", "tilt", "more"]
    region: str = ""  # show: "top left corner", "left edge", "centre", …
    count: int = 0  # more: frames still needed

    def text(self) -> str:
        if self.code == "start":
            return "hold the board in front of the camera"
        if self.code == "show":
            return f"show the board in the image's {self.region}"
        if self.code == "tilt":
            return "tilt the board towards the camera's sides (about 30°)"
        return f"{self.count} more frames at least"


class Coverage(BaseModel):
    """Where in the image the board's corners have been seen (counts per cell, rows of
    `columns` cells), and how the board was tilted towards the camera in each frame."""

    rows: int
    columns: int
    cells: list[list[int]]
    covered: float  # the share of cells seen at least once
    tilts: dict[str, int]  # flat, left, right, up, down: frames tilted so
    hints: list[str]  # what to show the camera next
    advice: list[Advice] = Field(default_factory=list)  # the same, as codes
    ready: bool  # enough frames, image covered and tilted: a solve can be trusted


class FrameReport(BaseModel):
    """One capture: kept (its index) or rejected, with the reason."""

    accepted: bool
    index: int | None = None
    reason: str = ""
    corners: int = 0
    points: list[list[float]] = Field(default_factory=list)  # the corners found (px)
    tilt: str = ""
    tilt_deg: float | None = None
    taken: float = 0.0  # when the image was taken


class SessionFrame(BaseModel):
    index: int
    corners: int
    tilt: str
    tilt_deg: float
    error: float | None = None  # px, after a solve
    outlier: bool = False


class IntrinsicSessionView(BaseModel):
    id: str
    camera: str
    board: BoardSpec
    width: int | None = None
    height: int | None = None
    frames: list[SessionFrame]
    rejected: int  # captures that were not kept
    coverage: Coverage
    min_frames: int
    result: CameraCalibration | None = None  # the last solve's


class IntrinsicStart(Strict):
    camera: str = Field(pattern=NAME)
    board: BoardSpec | None = None  # None: the stored setting `vision.board`


class OperationStatus(BaseModel):
    """A long operation (a solve, a robot-origin run): progress 0-1, its stage in words."""

    id: str
    kind: Literal["intrinsic", "extrinsic", "robot_origin"]
    state: Literal["running", "done", "failed", "cancelled"]
    progress: float
    stage: str
    error: str = ""
    # What it found, once done: a camera calibration (intrinsic), a camera's placement
    # (extrinsic), a robot's base (robot_origin).
    result: CameraCalibration | ExtrinsicResult | RobotOriginResult | None = None


class ExtrinsicRequest(Strict):
    """The camera's pose in the world from a board lying at a known pose: typed, or a
    stored `frame` or `pose` variable (taught)."""

    camera: str = Field(pattern=NAME)
    board: BoardSpec | None = None
    board_pose: Pose | None = None
    board_variable: str | None = Field(default=None, max_length=128)
    frames: int = Field(default=3, ge=1, le=30)


class ExtrinsicResult(BaseModel):
    camera: str
    pose: Pose  # the camera in the world (x right, y down the image, z along the view)
    frames: int
    reprojection: float  # px, RMS over the frames
    spread_mm: float  # how far the frames' estimates lie apart
    spread_deg: float


class FlangeTag(Strict):
    """The ArUco tag on the robot's flange: its id, printed side (m) and dictionary."""

    id: int = Field(default=0, ge=0, le=999)
    size: float = Field(default=0.06, gt=0.005, le=0.5)
    dictionary: Dictionary = "4x4_50"


class RobotOriginRequest(Strict):
    """Calibrate where `robot` stands in the world: it visits `poses` poses generated in
    `region` (or the taught joint waypoints named), `camera` finds the flange's tag at each."""

    robot: str = Field(pattern=NAME)
    camera: str = Field(pattern=NAME)
    tag: FlangeTag = Field(default_factory=FlangeTag)
    region: PoseRegion = Field(default_factory=PoseRegion)
    poses: int = Field(default=12, ge=4, le=40)
    waypoints: list[str] | None = Field(default=None, min_length=4, max_length=40)
    speed: float = Field(default=0.5, gt=0, le=1)


class OriginPose(BaseModel):
    index: int
    joints: list[float] | None = None
    seen: bool = False
    reason: str = ""  # why it was not used: unreachable, blocked, the tag not seen
    residual_px: float | None = None
    residual_mm: float | None = None
    outlier: bool = False


class RobotOriginResult(BaseModel):
    robot: str
    camera: str
    base: Pose  # the robot's base in the world, as found
    previous: Pose  # as it was stored before
    moved_mm: float  # from the previous
    moved_deg: float
    tag_on_flange: Pose
    rms_px: float
    poses: list[OriginPose]


class Located(Detection):
    """A detection with its pose in the world, where the camera is placed in it."""

    world_pose: Pose | None = None


class LocatedDetections(BaseModel):
    """What one image showed; `ts` is when it was taken and `age` how long before the answer
    (s): a program acting on a detection knows how old it is."""

    ts: float
    age: float
    detector: str
    camera: str
    width: int
    height: int
    calibrated: bool  # poses in the camera frame
    placed: bool  # and in the world
    detections: list[Located] = Field(default_factory=list)


class OperationSaved(BaseModel):
    operation: str
    saved: list[str]  # the variables written
