"""Calibration boards: a ChArUco board of any size and ArUco dictionary, or a plain
chessboard, as the user's setting describes it, and finding it in an image.

Both use one frame on the board: the origin at the printed pattern's top-left corner, x along
its columns, y down its rows, z into the print; inner corner (i, j) lies at
((i + 1) * square, (j + 1) * square, 0)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Annotated, Any, Literal

import cv2
import numpy as np
from pydantic import AfterValidator, Field, model_validator

from openpendant.runtime.interfaces.common import Strict

DICTIONARIES: dict[str, int] = {
    name.removeprefix("DICT_").lower(): getattr(cv2.aruco, name)
    for name in dir(cv2.aruco)
    if name.startswith("DICT_") and not name.endswith("_MAX")
}
REFINE = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)
MIN_CORNERS = 6  # below this a view pins down too little (and a homography needs 4)


def known_dictionary(name: str) -> str:
    if name not in DICTIONARIES:
        raise ValueError(f"no ArUco dictionary {name!r} (e.g. 4x4_50, 5x5_100, 6x6_250)")
    return name


# A marker dictionary's name, as OpenCV's predefined ones are called (lower case, no DICT_).
Dictionary = Annotated[str, Field(max_length=32), AfterValidator(known_dictionary)]


def dictionary_size(name: str) -> int:
    """How many markers a predefined dictionary holds."""
    dictionary = cv2.aruco.getPredefinedDictionary(DICTIONARIES[name])
    return int(dictionary.bytesList.shape[0])


class BoardSpec(Strict):
    """The board as printed: squares across and down, square and marker sizes in metres."""

    kind: Literal["charuco", "chessboard"] = "charuco"
    squares_x: int = Field(ge=3, le=40)
    squares_y: int = Field(ge=3, le=40)
    square: float = Field(gt=0.002, le=0.5)
    marker: float = Field(default=0.0, ge=0.0, le=0.5)  # ChArUco only
    dictionary: str = Field(default="5x5_100", max_length=32)  # ChArUco only

    @model_validator(mode="after")
    def _consistent(self) -> BoardSpec:
        if self.kind == "charuco":
            if self.dictionary not in DICTIONARIES:
                raise ValueError(
                    f"no ArUco dictionary {self.dictionary!r} (e.g. 5x5_100, 4x4_50, 6x6_250)"
                )
            if not 0 < self.marker < self.square:
                raise ValueError("a ChArUco board's markers must be smaller than its squares")
            markers = self.squares_x * self.squares_y // 2
            size = dictionary_size(self.dictionary)
            if markers > size:
                raise ValueError(
                    f"a {self.squares_x}x{self.squares_y} board needs {markers} markers; "
                    f"the dictionary {self.dictionary} has {size}"
                )
        return self

    @property
    def inner_corners(self) -> int:
        return (self.squares_x - 1) * (self.squares_y - 1)


@dataclass(frozen=True)
class BoardView:
    """The board's corners found in one image: where each is on the board (m) and in the
    image (px), with the ChArUco ids (or the chessboard's corner indices)."""

    ids: np.ndarray  # (n,) int
    board_points: np.ndarray  # (n, 3) float32
    image_points: np.ndarray  # (n, 2) float32


class NotSeen(Exception):
    """Why an image does not show the board well enough to use."""


class Board:
    def __init__(self, spec: BoardSpec) -> None:
        self.spec = spec

    @cached_property
    def _charuco(self) -> Any:
        dictionary = cv2.aruco.getPredefinedDictionary(DICTIONARIES[self.spec.dictionary])
        squares = (self.spec.squares_x, self.spec.squares_y)
        return cv2.aruco.CharucoBoard(squares, self.spec.square, self.spec.marker, dictionary)

    @cached_property
    def _charuco_detector(self) -> Any:
        return cv2.aruco.CharucoDetector(self._charuco)

    @cached_property
    def corners(self) -> np.ndarray:
        """Every inner corner on the board (m), by id."""
        nx, ny, square = self.spec.squares_x - 1, self.spec.squares_y - 1, self.spec.square
        j, i = np.mgrid[0:ny, 0:nx]
        points = np.stack([(i.ravel() + 1) * square, (j.ravel() + 1) * square], axis=1)
        return np.hstack([points, np.zeros((nx * ny, 1))]).astype(np.float32)

    def find(self, gray: np.ndarray) -> BoardView:
        """The board's corners in a greyscale image, refined to a fraction of a pixel."""
        if self.spec.kind == "chessboard":
            return self._find_chessboard(gray)
        corners, ids, _, _ = self._charuco_detector.detectBoard(gray)
        if ids is None or len(ids) == 0:
            raise NotSeen("no board in view")
        if len(ids) < MIN_CORNERS:
            raise NotSeen(f"only {len(ids)} of the board's corners seen (at least {MIN_CORNERS})")
        ids = ids.ravel().astype(int)
        return BoardView(ids, self.corners[ids], corners.reshape(-1, 2).astype(np.float32))

    def _find_chessboard(self, gray: np.ndarray) -> BoardView:
        size = (self.spec.squares_x - 1, self.spec.squares_y - 1)
        flags = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
        found, corners = cv2.findChessboardCornersSB(gray, size, flags=flags)
        if not found:
            raise NotSeen("no chessboard in view (a chessboard must be seen whole)")
        # The sector-based detector's corners are off by tenths of a pixel (a calibration
        # from them missed the focal length by 0.7 %); the saddle-point refinement is not.
        spacing = float(np.median(np.linalg.norm(np.diff(corners.reshape(-1, 2), axis=0), axis=1)))
        half = int(np.clip(spacing / 4, 2, 11))
        corners = cv2.cornerSubPix(gray, corners, (half, half), (-1, -1), REFINE)
        ids = np.arange(self.spec.inner_corners)
        return BoardView(ids, self.corners, corners.reshape(-1, 2).astype(np.float32))

    def generate(self, pixels_per_metre: float) -> np.ndarray:
        """The board's printed image (a test's or a print-out's)."""
        width = round(self.spec.squares_x * self.spec.square * pixels_per_metre)
        height = round(self.spec.squares_y * self.spec.square * pixels_per_metre)
        if self.spec.kind == "charuco":
            image = self._charuco.generateImage((width, height), marginSize=0)
            return np.asarray(image, dtype=np.uint8)
        y, x = np.mgrid[0:height, 0:width]
        cell = (x * self.spec.squares_x // width) + (y * self.spec.squares_y // height)
        return np.where(cell % 2 == 0, 0, 255).astype(np.uint8)
