"""Vision, on one core: ArUco detection (the cell's tagged parts, corners located from the
markers' edges) at three image sizes; an intrinsic calibration's solve from 30 rendered
ChArUco frames; a robot-origin solve from 15 flange-tag sightings with 0.2 px of noise.
Images come from the simulated camera's renderer (what a real camera would deliver)."""

from __future__ import annotations

import time

import cv2
import numpy as np

from openpendant.device_drivers.sim_camera.entry import SimCameraOptions, camera_model
from openpendant.device_drivers.sim_camera.optics import Renderer, Target
from openpendant.device_drivers.sim_camera.scene import cell_targets
from openpendant.device_drivers.sim_cell.world import World
from openpendant.runtime.bench.harness.views import board_views
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick
from openpendant.runtime.imaging.boards import Board, BoardSpec
from openpendant.runtime.imaging.markers import find_markers
from openpendant.runtime.imaging.template import find_template
from openpendant.runtime.interfaces.common import Pose
from openpendant.runtime.vision.intrinsics import IntrinsicSession
from openpendant.runtime.vision.models import PoseRegion
from openpendant.runtime.vision.poses import flange_poses
from openpendant.runtime.vision.robot_origin import Camera, Sighting, solve_origin, tag_corners

FIGURES = (
    "aruco_fps_640",
    "aruco_fps_1280",
    "aruco_fps_1920",
    "template_match_ms",
    "intrinsic_solve_s",
    "robot_origin_solve_ms",
)
SIZES = ((640, 400), (1280, 800), (1920, 1080))
ARUCO_TARGET_FPS = 30.0  # at 1080p


def _aruco(width: int, height: int, seconds: float) -> Figure:
    model = camera_model(SimCameraOptions(width=width, height=height))
    scene = World(lambda: Pose()).scene()
    image = Renderer(model).render(cell_targets(scene, "4x4_50"), noise=1.0)
    found = find_markers(image, "4x4_50")
    frames, started = 0, time.perf_counter()
    while time.perf_counter() - started < seconds:
        find_markers(image, "4x4_50")
        frames += 1
    fps = frames / (time.perf_counter() - started)
    target = f">= {ARUCO_TARGET_FPS:g}" if width == 1920 else ""
    return Figure(
        f"aruco_fps_{width}",
        fps,
        "fps",
        target=target,
        meets_target=fps >= ARUCO_TARGET_FPS if target else None,
        details={"size": f"{width}x{height}", "markers": sorted(found), "threads": 1},
    )


def _template(repeats: int) -> Figure:
    """A part's face cut from a 1280x800 view of the cell, found again in it (turned by any
    angle in 10° steps, scaled 0.9-1.1)."""
    model = camera_model(SimCameraOptions())
    scene = World(lambda: Pose()).scene()
    image = Renderer(model).render(cell_targets(scene, "4x4_50"), noise=1.0)
    centre = model.matrix @ (np.linalg.inv(model.pose) @ np.array([0.45, 0.0, 0.04, 1.0]))[:3]
    u, v = (centre[:2] / centre[2]).round().astype(int)
    template = image[v - 30 : v + 30, u - 30 : u + 30]
    times, found = [], []
    for _ in range(repeats):
        started = time.perf_counter()
        found = find_template(image, template)
        times.append((time.perf_counter() - started) * 1000)
    return Figure(
        "template_match_ms",
        percentile(times, 50),
        "ms",
        details={
            "image": f"{model.width}x{model.height}",
            "template": "60x60",
            "angles": "0-350 by 10°, refined",
            "scales": "0.9-1.1 by 0.1",
            "matches": len(found),
            "threads": 1,
        },
    )


def _intrinsic(frames: int) -> Figure:
    model = camera_model(SimCameraOptions())
    truth = {
        "width": model.width,
        "height": model.height,
        "fx": model.fx,
        "fy": model.fy,
        "cx": model.cx,
        "cy": model.cy,
        "distortion": list(model.coefficients),
    }
    spec = BoardSpec(squares_x=9, squares_y=6, square=0.03, marker=0.022)
    board = Board(spec)
    texture, size = board.generate(4000.0), (0.27, 0.18)
    renderer = Renderer(model)
    session = IntrinsicSession("bench", board)
    rng = np.random.default_rng(30)
    for index, pose in enumerate(board_views(truth, size, frames)):
        image = renderer.render([Target(texture, *size, model.pose @ pose)], noise=1.0, rng=rng)
        session.add(image, float(index))
    started = time.perf_counter()
    found = session.solve(lambda _p, _s: None).calibration
    seconds = time.perf_counter() - started
    return Figure(
        "intrinsic_solve_s",
        seconds,
        "s",
        details={
            "frames": len(session.frames),
            "rejected": session.rejected,
            "rms_px": round(found.rms, 4),
            "focal_error_percent": round(abs(found.intrinsics.fx / model.fx - 1) * 100, 4),
        },
    )


def _robot_origin(repeats: int) -> Figure:
    model = camera_model(SimCameraOptions())
    camera = Camera(model.matrix, model.coefficients, model.pose)
    rng = np.random.default_rng(15)
    base = np.eye(4)
    base[:3, 3] = [0.05, -0.02, 0.0]
    tag = np.eye(4)
    tag[:3, 3] = [0.0, 0.0, 0.005]
    region = PoseRegion(centre=[0.45, 0.0, 0.45], size=[0.3, 0.3, 0.2])
    sightings = []
    for flange in flange_poses(region, (np.linalg.inv(base) @ model.pose)[:3, 3], 15, seed=3):
        in_camera = np.linalg.inv(model.pose) @ base @ flange @ tag
        at, _ = cv2.projectPoints(
            tag_corners(0.06),
            cv2.Rodrigues(in_camera[:3, :3])[0],
            in_camera[:3, 3],
            camera.matrix,
            camera.distortion,
        )
        sightings.append(Sighting(flange, at.reshape(-1, 2) + rng.normal(0, 0.2, (4, 2))))
    times, error_mm = [], 0.0
    for _ in range(repeats):
        started = time.perf_counter()
        found = solve_origin(sightings, 0.06, camera, lambda _p, _s: None)
        times.append((time.perf_counter() - started) * 1000)
        error_mm = float(np.linalg.norm(found.base[:3, 3] - base[:3, 3]) * 1000)
    return Figure(
        "robot_origin_solve_ms",
        percentile(times, 50),
        "ms",
        details={"poses": len(sightings), "noise_px": 0.2, "base_error_mm": round(error_mm, 3)},
    )


def run() -> list[Figure]:
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # "one core": the figure a camera's share of a pendant's CPU gives
    try:
        seconds = 1.0 if quick() else 5.0
        figures = [_aruco(width, height, seconds) for width, height in SIZES]
        figures.append(_template(3 if quick() else 20))
        figures.append(_intrinsic(10 if quick() else 30))
        figures.append(_robot_origin(3 if quick() else 20))
    finally:
        cv2.setNumThreads(threads)
    return figures
