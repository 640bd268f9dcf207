"""The vision service's calibration core (issue 17), on images the simulated camera's optics
render from a known camera: a guided intrinsic session (frames kept or rejected with the
reason, coverage and hints, the solve with its uncertainties, frames that disagree left out),
the chessboard fallback, OpenCV YAML both ways, and a camera placed in the world from a board
at a known pose."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.optics import CameraModel, Renderer, Target, look_at
from openpendant.runtime.bench.harness.views import board_views
from openpendant.runtime.imaging.boards import Board, BoardSpec, BoardView
from openpendant.runtime.kit.errors import Conflict, InvalidValue
from openpendant.runtime.vision.calibration_file import from_yaml, to_yaml
from openpendant.runtime.vision.extrinsics import average, board_in_camera, camera_in_world
from openpendant.runtime.vision.intrinsics import MIN_FRAMES, IntrinsicSession
from openpendant.runtime.vision.models import CameraCalibration

EYE = look_at(np.array([0.4, 0.1, 0.9]), np.array([0.45, 0.0, 0.0]), np.array([1.0, 0, 0]))
CAMERA = CameraModel(640, 400, 520.0, 522.0, 318.5, 203.0, (-0.1, 0.04, 0.0004, -0.0002, 0.0), EYE)
CHARUCO = BoardSpec(squares_x=9, squares_y=6, square=0.03, marker=0.022, dictionary="5x5_100")
TRUTH = {
    "width": CAMERA.width,
    "height": CAMERA.height,
    "fx": CAMERA.fx,
    "fy": CAMERA.fy,
    "cx": CAMERA.cx,
    "cy": CAMERA.cy,
    "distortion": list(CAMERA.distortion),
}


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(CAMERA)


def shoot(renderer: Renderer, board: Board, pose: np.ndarray, seed: int = 0) -> np.ndarray:
    """The board at `pose` in the world, through the camera."""
    size = (board.spec.squares_x * board.spec.square, board.spec.squares_y * board.spec.square)
    texture = board.generate(4000.0)
    rng = np.random.default_rng(seed)
    return renderer.render([Target(texture, *size, pose)], noise=2.0, rng=rng)


def session_of(renderer: Renderer, spec: BoardSpec, count: int) -> IntrinsicSession:
    board = Board(spec)
    session = IntrinsicSession("camera", board)
    size = (spec.squares_x * spec.square, spec.squares_y * spec.square)
    for index, pose in enumerate(board_views(TRUTH, size, count)):
        report = session.add(shoot(renderer, board, CAMERA.pose @ pose, index), float(index))
        assert report.accepted, report.reason
    return session


def test_a_guided_session_says_what_to_show_then_solves_to_the_true_camera(
    renderer: Renderer,
) -> None:
    board = Board(CHARUCO)
    session = IntrinsicSession("camera", board)
    assert not session.coverage().ready
    empty = session.add(np.full((400, 640), 128, np.uint8), 0.0)
    assert not empty.accepted and empty.reason == "no board in view"
    poses = [CAMERA.pose @ pose for pose in board_views(TRUTH, (0.27, 0.18), 14)]
    first = session.add(shoot(renderer, board, poses[0]), 1.0)
    assert first.accepted and first.index == 0 and first.corners == 40
    again = session.add(shoot(renderer, board, poses[0], seed=5), 2.0)
    assert not again.accepted and "frame 1" in again.reason
    guidance = session.coverage()
    assert not guidance.ready
    assert any("corner" in hint for hint in guidance.hints)
    assert any("tilt" in hint for hint in guidance.hints)
    codes = [a.code for a in guidance.advice]  # the same, for a UI to word in its language
    assert "tilt" in codes and any(
        a.code == "show" and "corner" in a.region for a in guidance.advice
    )
    for index, pose in enumerate(poses[1:], start=1):
        assert session.add(shoot(renderer, board, pose, index), float(index)).accepted
    coverage = session.coverage()
    assert coverage.ready, coverage.hints
    assert coverage.covered >= 0.75
    assert {name for name, n in coverage.tilts.items() if n} >= {"left", "right", "up", "down"}
    assert session.rejected == 2

    stages: list[str] = []
    solution = session.solve(lambda _p, stage: stages.append(stage))
    found = solution.calibration
    assert stages[0] == "solving" and solution.outliers == []
    assert found.rms <= 0.3
    assert found.intrinsics.fx == pytest.approx(CAMERA.fx, rel=0.005)
    assert found.intrinsics.fy == pytest.approx(CAMERA.fy, rel=0.005)
    assert found.intrinsics.cx == pytest.approx(CAMERA.cx, abs=2.0)
    assert found.intrinsics.distortion[0] == pytest.approx(CAMERA.distortion[0], abs=0.01)
    assert set(found.uncertainty) >= {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}
    assert 0 < found.uncertainty["fx"] < 0.005 * CAMERA.fx
    assert len(found.frame_errors) == len(session.frames) == 14
    assert all(view.error is not None for view in session.frame_views())


def test_a_frame_that_disagrees_with_the_rest_is_left_out(renderer: Renderer) -> None:
    session = session_of(renderer, CHARUCO, MIN_FRAMES)
    bad = session.frames[3].view
    # As a board that moved while the frame was exposed: half its corners a few px off.
    shifted = bad.image_points.copy()
    shifted[: len(shifted) // 2] += 4.0
    session.frames[3].view = BoardView(bad.ids, bad.board_points, shifted)
    solution = session.solve(lambda _p, _s: None)
    assert solution.outliers == [3]
    assert session.frame_views()[3].outlier
    assert solution.calibration.rms <= 0.3
    assert len(solution.calibration.frame_errors) == MIN_FRAMES - 1


def test_too_few_frames_is_a_clear_error_and_frames_can_be_dropped(renderer: Renderer) -> None:
    session = session_of(renderer, CHARUCO, 4)
    session.remove(0)
    with pytest.raises(InvalidValue, match="needs 4"):
        session.solve(lambda _p, _s: None)
    with pytest.raises(InvalidValue, match="no frame 9"):
        session.remove(8)


def test_a_chessboard_calibrates_the_camera_too(renderer: Renderer) -> None:
    spec = BoardSpec(kind="chessboard", squares_x=8, squares_y=6, square=0.03)
    found = session_of(renderer, spec, MIN_FRAMES).solve(lambda _p, _s: None).calibration
    assert found.rms <= 0.3
    assert found.intrinsics.fx == pytest.approx(CAMERA.fx, rel=0.005)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"marker": 0.03}, "smaller than its squares"),
        ({"dictionary": "5x5_1000000"}, "no ArUco dictionary"),
        ({"squares_x": 20, "squares_y": 20, "dictionary": "4x4_50"}, "has 50"),
        ({"square": float("nan")}, "finite"),
    ],
)
def test_a_board_that_cannot_exist_is_refused(fields: dict[str, object], message: str) -> None:
    with pytest.raises(ValidationError, match=message):
        BoardSpec.model_validate({**CHARUCO.model_dump(), **fields})


def test_a_calibration_goes_to_opencv_yaml_and_back(renderer: Renderer) -> None:
    found = session_of(renderer, CHARUCO, MIN_FRAMES).solve(lambda _p, _s: None).calibration
    text = to_yaml(found)
    assert text.startswith("%YAML:1.0") and "camera_matrix: !!opencv-matrix" in text
    back = from_yaml(text, "other")
    assert back.camera == "other"
    k, k0 = back.intrinsics, found.intrinsics
    assert (k.width, k.height) == (k0.width, k0.height)
    assert [k.fx, k.fy, k.cx, k.cy] == pytest.approx([k0.fx, k0.fy, k0.cx, k0.cy], rel=1e-12)
    assert k.distortion == pytest.approx(k0.distortion, rel=1e-12)
    assert back.rms == pytest.approx(found.rms)


def test_another_tools_yaml_is_read_and_a_broken_one_refused() -> None:
    written_by_opencvs_sample = """%YAML:1.0
---
image_width: 1920
image_height: 1080
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1400.5, 0., 960.2, 0., 1401.1, 541.7, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -0.21, 0.05, 0.001, -0.0005, 0. ]
avg_reprojection_error: 0.31
"""
    found = from_yaml(written_by_opencvs_sample, "camera")
    assert (found.intrinsics.width, found.intrinsics.height) == (1920, 1080)
    assert found.intrinsics.fy == 1401.1 and found.intrinsics.distortion[0] == -0.21
    for broken in (
        "not: yaml: at all: [",
        written_by_opencvs_sample.replace("rows: 3\n   cols: 3", "rows: 1\n   cols: 9"),
        written_by_opencvs_sample.replace("1400.5", ".nan"),
        written_by_opencvs_sample.replace("image_width: 1920\n", ""),
        written_by_opencvs_sample.replace("rows: 5", "rows: 3").replace(", 0.001, -0.0005", ""),
    ):
        with pytest.raises(InvalidValue):
            from_yaml(broken, "camera")


def test_the_camera_is_placed_in_the_world_from_a_board_at_a_known_pose(
    renderer: Renderer,
) -> None:
    # Printed large enough to be read whole at 0.9 m by this 640-pixel camera.
    board = Board(CHARUCO.model_copy(update={"square": 0.06, "marker": 0.045}))
    board_in_world = np.eye(4)
    board_in_world[:3, :3] = (
        Rotation.from_euler("x", 180, degrees=True) * Rotation.from_euler("z", 15, degrees=True)
    ).as_matrix()
    # Its centre under the camera's view point, on the table.
    board_in_world[:3, 3] = [0.45, 0.0, 0.0] - board_in_world[:3, :3] @ [0.27, 0.18, 0.0]
    intrinsics = CameraCalibration.model_validate(
        {"camera": "camera", "intrinsics": TRUTH, "rms": 0.0, "calibrated": 0.0}
    ).intrinsics
    estimates = []
    for seed in range(3):
        image = shoot(renderer, board, board_in_world, seed)
        view = board.find(image)
        assert len(view.ids) == 40
        found = board_in_camera(view, intrinsics)
        assert found.error < 0.3
        estimates.append(camera_in_world(board_in_world, found.matrix))
    mean = average(estimates)
    assert np.linalg.norm(mean.matrix[:3, 3] - CAMERA.pose[:3, 3]) < 0.001
    turned = Rotation.from_matrix(mean.matrix[:3, :3] @ CAMERA.pose[:3, :3].T).magnitude()
    assert np.degrees(turned) < 0.1
    assert mean.spread_m < 0.001 and mean.spread_deg < 0.1


def test_frames_do_not_change_while_a_solve_runs(renderer: Renderer) -> None:
    session = session_of(renderer, CHARUCO, 4)
    session.solving = True  # as while a solve works in its thread
    with pytest.raises(Conflict, match="a solve is running"):
        session.remove(0)
    with pytest.raises(Conflict, match="a solve is running"):
        session.add(np.full((400, 640), 128, np.uint8), 0.0)
    with pytest.raises(Conflict, match="a solve is running"):
        session.solve(lambda _p, _s: None)
    session.solving = False
    assert len(session.frames) == 4
