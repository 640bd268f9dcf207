"""The simulated camera as the driver host starts it (`openpendant driver sim-camera`): a
camera above the cell's table looking down at it, and a ChArUco board to put in its view.
Its own routes (`/sim/…`) are the world's side: where the board lies, and the ground truth
(the camera model and every pose) that tests measure a calibration against."""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.driver import CELL_WAIT, Board, SimCamera
from openpendant.device_drivers.sim_camera.optics import CameraModel, look_at
from openpendant.device_drivers.sim_cell.link import CellClient
from openpendant.runtime.imaging.boards import DICTIONARIES, BoardSpec
from openpendant.runtime.imaging.boards import Board as VisionBoard
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.errors import InvalidValue

BOARD_DPI_M = 4000.0  # the printed board's texture: pixels per metre (0.25 mm a pixel)


class SimCameraOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    width: int = Field(default=1280, ge=16, le=4096, description="image width (px)")
    height: int = Field(default=800, ge=16, le=4096, description="image height (px)")
    fov: float = Field(default=60.0, gt=5, lt=150, description="horizontal field of view (°)")
    k1: float = Field(default=-0.08, ge=-1, le=1, description="radial distortion k1")
    k2: float = Field(default=0.03, ge=-1, le=1, description="radial distortion k2")
    x: float = Field(default=0.45, ge=-10, le=10, description="camera position x (m, world)")
    y: float = Field(default=0.0, ge=-10, le=10, description="camera position y (m)")
    z: float = Field(default=1.0, ge=-10, le=10, description="camera position z (m)")
    look_x: float = Field(default=0.45, ge=-10, le=10, description="looks at x (m)")
    look_y: float = Field(default=0.0, ge=-10, le=10, description="looks at y (m)")
    look_z: float = Field(default=0.0, ge=-10, le=10, description="looks at z (m)")
    fps: float = Field(default=10.0, gt=0, le=60, description="frames a second at most")
    noise: float = Field(default=1.0, ge=0, le=50, description="sensor noise (grey levels)")
    blur: float = Field(default=0.0, ge=0, le=10, description="defocus blur sigma (px)")
    squares_x: int = Field(default=9, ge=3, le=30, description="board squares across")
    squares_y: int = Field(default=6, ge=3, le=30, description="board squares down")
    square: float = Field(default=0.03, gt=0.002, le=0.2, description="board square (m)")
    marker: float = Field(default=0.022, gt=0.001, le=0.2, description="board marker (m)")
    dictionary: str = Field(default="5x5_100", description="the board's ArUco dictionary")
    cell: str | None = Field(
        default=None,
        max_length=64,
        description="the simulated robot whose cell is in view (its parts and flange tag)",
    )
    tags: str = Field(default="4x4_50", description="the ArUco dictionary of the cell's tags")
    cell_wait: float = Field(
        default=CELL_WAIT,
        ge=0,
        le=600,
        description="seconds the --cell robot may take to come up before it is an error",
    )

    def default_name(self) -> str:
        return "sim-camera"


def camera_model(options: SimCameraOptions) -> CameraModel:
    eye = np.array([options.x, options.y, options.z])
    target = np.array([options.look_x, options.look_y, options.look_z])
    if np.linalg.norm(target - eye) < 1e-6:
        raise InvalidValue("the camera cannot look at the point it stands on")
    forward = (target - eye) / np.linalg.norm(target - eye)
    # Image rows run along the world's -x when looking straight down, else downwards.
    up = np.array([1.0, 0.0, 0.0]) if abs(forward[2]) > 0.99 else np.array([0.0, 0.0, 1.0])
    focal = options.width / 2 / np.tan(np.radians(options.fov) / 2)
    return CameraModel(
        options.width,
        options.height,
        focal,
        focal,
        (options.width - 1) / 2,
        (options.height - 1) / 2,
        (options.k1, options.k2, 0.0, 0.0, 0.0),
        look_at(eye, target, up),
    )


def charuco_board(options: SimCameraOptions) -> Board:
    try:
        spec = BoardSpec(
            squares_x=options.squares_x,
            squares_y=options.squares_y,
            square=options.square,
            marker=options.marker,
            dictionary=options.dictionary,
        )
    except ValidationError as exc:
        raise InvalidValue(describe_validation_errors(exc.errors())[0]) from None
    texture = VisionBoard(spec).generate(BOARD_DPI_M)
    width, height = options.squares_x * options.square, options.squares_y * options.square
    squares = (options.squares_x, options.squares_y)
    return Board(
        texture, width, height, squares, options.square, options.marker, options.dictionary
    )


def create(name: str, uuid: str, options: SimCameraOptions) -> SimCamera:
    if options.tags not in DICTIONARIES:
        raise InvalidValue(f"no ArUco dictionary {options.tags!r} (e.g. 4x4_50, 5x5_100)")
    identity = DeviceIdentity(uuid=uuid, kind="camera", model="simulated camera", name=name)
    return SimCamera(
        identity,
        camera_model(options),
        charuco_board(options),
        fps=options.fps,
        noise=options.noise,
        blur=options.blur,
        cell=CellClient(options.cell) if options.cell else None,
        tags=options.tags,
        cell_wait=options.cell_wait,
    )


class BoardPlacement(BaseModel):
    """Where the board lies (its printed face's top-left corner, x along its columns, y down
    its rows, z into the print), or null: put away."""

    model_config = ConfigDict(extra="forbid")

    pose: Pose | None


def _matrix(pose: Pose) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(pose.orientation).as_matrix()  # x, y, z, w
    matrix[:3, 3] = pose.position
    return matrix


def _pose(matrix: np.ndarray) -> dict[str, object]:
    quaternion = Rotation.from_matrix(matrix[:3, :3]).as_quat()  # x, y, z, w
    return {"position": matrix[:3, 3].tolist(), "orientation": quaternion.tolist()}


def routes(driver: SimCamera) -> APIRouter:
    router = APIRouter(prefix="/sim")

    @router.put("/board")
    async def put_board(body: BoardPlacement) -> dict[str, object]:
        driver.put_board(None if body.pose is None else _matrix(body.pose))
        return truth()

    @router.get("/truth")
    def truth() -> dict[str, object]:
        """The camera model and pose and the board's, as the images were made."""
        camera, board = driver.camera, driver.board
        return {
            "camera": {
                "width": camera.width,
                "height": camera.height,
                "fx": camera.fx,
                "fy": camera.fy,
                "cx": camera.cx,
                "cy": camera.cy,
                "distortion": camera.coefficients.tolist(),
                "pose": _pose(camera.pose),
            },
            "board": {
                "squares": list(board.squares),
                "square": board.square,
                "marker": board.marker,
                "dictionary": board.dictionary,
                "pose": None if driver.board_pose is None else _pose(driver.board_pose),
            },
            # The cell as the last frame showed it (the robot's true base, parts, flange tag).
            "cell": driver.scene,
            "tags": driver.tags,
        }

    return router
