"""A guided intrinsic calibration: frames of a board are kept or rejected with the reason,
the coverage of the image and the board's tilts say what to show the camera next, and the
solve reports the RMS error, each parameter's uncertainty and each frame's error, leaving
out frames that disagree with the rest."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from openpendant.runtime.imaging.boards import Board, BoardView, NotSeen
from openpendant.runtime.interfaces.camera import Intrinsics
from openpendant.runtime.kit.errors import Conflict, InvalidValue
from openpendant.runtime.vision.models import (
    Advice,
    CameraCalibration,
    Coverage,
    FrameReport,
    SessionFrame,
)

GRID = (4, 6)  # rows, columns of the coverage map
MIN_FRAMES = 10  # for a solve to be trusted (one can be asked for from MIN_SOLVE)
MIN_SOLVE = 4
READY_COVERAGE = 0.75
FLAT_DEG = 15.0  # a board tilted less than this towards the camera counts as flat
# A frame whose corners lie within this share of the image's diagonal of an earlier frame's,
# the board turned less than SAME_TILT from it, adds nothing.
SAME_VIEW, SAME_TILT = 0.02, 8.0
OUTLIER_FACTOR, OUTLIER_FLOOR = 3.0, 0.5  # a frame's error beyond both: left out (px)
PARAMETERS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
REGIONS = (("top", "middle", "bottom"), ("left", "centre", "right"))

Progress = Callable[[float, str], None]


@dataclass
class Kept:
    view: BoardView
    tilt: str
    tilt_deg: float
    normal: np.ndarray  # the board's z in the (guessed) camera frame
    error: float | None = None
    outlier: bool = False
    cells: set[tuple[int, int]] = field(default_factory=set)


@dataclass(frozen=True)
class Solution:
    calibration: CameraCalibration
    outliers: list[int]


class IntrinsicSession:
    def __init__(self, camera: str, board: Board) -> None:
        self.camera = camera
        self.board = board
        self.size: tuple[int, int] | None = None  # width, height
        self.frames: list[Kept] = []
        self.rejected = 0
        # Captures run in worker threads and a solve in another: frames change under the
        # lock, and not at all while a solve works on them.
        self.lock = threading.Lock()
        self.solving = False

    # Capturing ------------------------------------------------------------------------------

    def add(self, gray: np.ndarray, taken: float) -> FrameReport:
        with self.lock:
            self._idle()
            return self._add(gray, taken)

    def _idle(self) -> None:
        if self.solving:
            raise Conflict("a solve is running: change the frames after it", code="solving")

    def _add(self, gray: np.ndarray, taken: float) -> FrameReport:
        height, width = gray.shape[:2]
        if self.size is not None and self.size != (width, height):
            self.rejected += 1
            w, h = self.size
            return FrameReport(
                accepted=False,
                reason=f"the image is {width}x{height}, the session's {w}x{h}",
                taken=taken,
            )
        try:
            view = self.board.find(gray)
        except NotSeen as exc:
            self.rejected += 1
            return FrameReport(accepted=False, reason=str(exc), taken=taken)
        self.size = (width, height)
        points = view.image_points.tolist()
        normal = self._normal(view)
        similar = self._similar(view, normal)
        if similar is not None:
            self.rejected += 1
            return FrameReport(
                accepted=False,
                reason=f"the board is where frame {similar + 1} saw it: move or tilt it",
                corners=len(view.ids),
                points=points,
                taken=taken,
            )
        tilt, degrees = _tilt(normal)
        kept = Kept(view, tilt, degrees, normal, cells=self._cells(view))
        self.frames.append(kept)
        return FrameReport(
            accepted=True,
            index=len(self.frames) - 1,
            corners=len(view.ids),
            points=points,
            tilt=tilt,
            tilt_deg=round(degrees, 1),
            taken=taken,
        )

    def remove(self, index: int) -> None:
        with self.lock:
            self._idle()
            if not 0 <= index < len(self.frames):
                raise InvalidValue(f"no frame {index + 1}", code="no_such_frame")
            del self.frames[index]

    def _similar(self, view: BoardView, normal: np.ndarray) -> int | None:
        """An earlier frame that saw the board where this one does, turned the same way."""
        assert self.size is not None
        diagonal = float(np.hypot(*self.size))
        for index, kept in enumerate(self.frames):
            if np.degrees(np.arccos(np.clip(normal @ kept.normal, -1, 1))) > SAME_TILT:
                continue
            common, mine, theirs = np.intersect1d(view.ids, kept.view.ids, return_indices=True)
            if len(common) < 0.8 * max(len(view.ids), len(kept.view.ids)):
                continue
            moved = np.linalg.norm(
                view.image_points[mine] - kept.view.image_points[theirs], axis=1
            ).mean()
            if moved < SAME_VIEW * diagonal:
                return index
        return None

    def _cells(self, view: BoardView) -> set[tuple[int, int]]:
        assert self.size is not None
        width, height = self.size
        rows, columns = GRID
        at = view.image_points
        row = np.clip((at[:, 1] * rows / height).astype(int), 0, rows - 1)
        column = np.clip((at[:, 0] * columns / width).astype(int), 0, columns - 1)
        return set(zip(row.tolist(), column.tolist(), strict=True))

    def _normal(self, view: BoardView) -> np.ndarray:
        """Which way the board faces, from its pose under a guessed camera (a focal length
        of the image's larger side): good enough to tell the ways it was tilted."""
        assert self.size is not None
        width, height = self.size
        f = float(max(width, height))
        guess = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1]])
        ok, rvec, _ = cv2.solvePnP(view.board_points, view.image_points, guess, None)
        if not ok:
            return np.array([0.0, 0.0, 1.0])
        normal = cv2.Rodrigues(rvec)[0][:, 2]  # the board's z, into the print
        return np.asarray(normal * np.sign(normal[2] or 1.0))

    # Guidance -------------------------------------------------------------------------------

    def coverage(self) -> Coverage:
        rows, columns = GRID
        cells = np.zeros(GRID, dtype=int)
        tilts = dict.fromkeys(("flat", "left", "right", "up", "down"), 0)
        for kept in self.frames:
            for r, c in kept.cells:
                cells[r, c] += 1
            tilts[kept.tilt] += 1
        covered = float((cells > 0).mean())
        advice = self._advice(cells, tilts)
        ready = (
            len(self.frames) >= MIN_FRAMES
            and covered >= READY_COVERAGE
            and not any(a.code == "tilt" for a in advice)
        )
        return Coverage(
            rows=rows,
            columns=columns,
            cells=cells.tolist(),
            covered=round(covered, 3),
            tilts=tilts,
            hints=[a.text() for a in advice],
            advice=advice,
            ready=ready,
        )

    def _advice(self, cells: np.ndarray, tilts: dict[str, int]) -> list[Advice]:
        if not self.frames:
            return [Advice(code="start")]
        advice: list[Advice] = []
        rows, columns = GRID
        empty: dict[str, int] = {}
        for r in range(rows):
            for c in range(columns):
                if cells[r, c] == 0:
                    name = _region(int((r + 0.5) * 3 / rows), int((c + 0.5) * 3 / columns))
                    empty[name] = empty.get(name, 0) + 1
        # The image's corners first: distortion is largest there and only they pin it down.
        order = sorted(empty, key=lambda name: (not name.endswith("corner"), -empty[name]))
        advice.extend(Advice(code="show", region=name) for name in order[:2])
        tilted = [name for name in ("left", "right", "up", "down") if tilts[name] > 0]
        if len(tilted) < 2:
            advice.append(Advice(code="tilt"))
        if len(self.frames) < MIN_FRAMES:
            advice.append(Advice(code="more", count=MIN_FRAMES - len(self.frames)))
        return advice

    def frame_views(self) -> list[SessionFrame]:
        return [
            SessionFrame(
                index=i,
                corners=len(k.view.ids),
                tilt=k.tilt,
                tilt_deg=round(k.tilt_deg, 1),
                error=None if k.error is None else round(k.error, 4),
                outlier=k.outlier,
            )
            for i, k in enumerate(self.frames)
        ]

    # Solving --------------------------------------------------------------------------------

    def solve(self, progress: Progress) -> Solution:
        """Runs off the event loop (seconds for dozens of frames)."""
        with self.lock:
            self._idle()
            self.solving = True
        try:
            return self._solve(progress)
        finally:
            with self.lock:
                self.solving = False

    def _solve(self, progress: Progress) -> Solution:
        if len(self.frames) < MIN_SOLVE or self.size is None:
            raise InvalidValue(
                f"{len(self.frames)} frames kept: a solve needs {MIN_SOLVE} at least",
                code="too_few_frames",
            )
        for kept in self.frames:
            kept.error, kept.outlier = None, False
        progress(0.1, "solving")
        use = list(range(len(self.frames)))
        rms, matrix, distortion, deviations, errors = self._calibrate(use)
        median = float(np.median(errors))
        limit = max(OUTLIER_FACTOR * median, OUTLIER_FLOOR)
        outliers = [i for i, e in zip(use, errors, strict=True) if e > limit]
        if outliers and len(use) - len(outliers) >= MIN_SOLVE:
            progress(0.6, f"solving again without {len(outliers)} frames that disagree")
            use = [i for i in use if i not in outliers]
            rms, matrix, distortion, deviations, errors = self._calibrate(use)
        else:
            outliers = []
        for i, error in zip(use, errors, strict=True):
            self.frames[i].error = float(error)
        for i in outliers:
            self.frames[i].outlier = True
        progress(0.9, "checking the result")
        width, height = self.size
        coefficients = [float(v) for v in distortion.ravel()]
        uncertainty = {
            name: float(value) for name, value in zip(PARAMETERS, deviations.ravel(), strict=False)
        }
        calibration = CameraCalibration(
            camera=self.camera,
            intrinsics=Intrinsics(
                width=width,
                height=height,
                fx=float(matrix[0, 0]),
                fy=float(matrix[1, 1]),
                cx=float(matrix[0, 2]),
                cy=float(matrix[1, 2]),
                distortion=coefficients,
            ),
            rms=float(rms),
            uncertainty=uncertainty,
            frame_errors=[round(float(e), 4) for e in errors],
            board=self.board.spec,
            calibrated=time.time(),
        )
        return Solution(calibration, outliers)

    def _calibrate(
        self, use: list[int]
    ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        assert self.size is not None
        objects = [self.frames[i].view.board_points for i in use]
        images = [self.frames[i].view.image_points for i in use]
        rms, matrix, distortion, _, _, deviations, _, errors = cv2.calibrateCameraExtended(
            objects,
            images,
            self.size,
            None,  # type: ignore[call-overload]  # OpenCV makes the first guess itself
            None,
        )
        if not np.isfinite(rms) or not np.all(np.isfinite(matrix)):
            raise InvalidValue("the solve did not converge: take more varied frames")
        return float(rms), matrix, distortion, deviations, np.asarray(errors).ravel()


def _tilt(normal: np.ndarray) -> tuple[str, float]:
    degrees = float(np.degrees(np.arccos(np.clip(normal[2], 0.0, 1.0))))
    if degrees < FLAT_DEG:
        return "flat", degrees
    if abs(normal[0]) >= abs(normal[1]):
        return ("left" if normal[0] > 0 else "right"), degrees
    return ("up" if normal[1] > 0 else "down"), degrees


def _region(row: int, column: int) -> str:
    vertical, horizontal = REGIONS[0][row], REGIONS[1][column]
    if vertical == "middle" and horizontal == "centre":
        return "centre"
    if vertical == "middle":
        return f"{horizontal} edge"
    if horizontal == "centre":
        return f"{vertical} edge"
    return f"{vertical} {horizontal} corner"
