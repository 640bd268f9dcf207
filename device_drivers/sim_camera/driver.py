"""A simulated camera as the standard camera: each capture renders what lies in front of it
now (a calibration board where it was put), through its camera model, with the sensor's
noise. It does not tell its intrinsics (a real camera does not either: that is what
calibrating it finds); its ground truth is for tests, at the simulator's own routes."""

from __future__ import annotations

import asyncio
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from device_drivers.sim_camera.optics import CameraModel, Gray, Renderer, Target
from device_drivers.sim_camera.scene import cell_targets
from device_drivers.sim_cell.link import CellClient
from runtime.imaging.encoding import encoded
from runtime.interfaces.camera import (
    CameraDriver,
    CameraInfo,
    CameraState,
    CaptureRequest,
    Image,
)
from runtime.interfaces.device import DeviceIdentity
from runtime.kit.errors import DeviceError


@dataclass(frozen=True)
class Board:
    """A ChArUco board: its printed image and size; `pose` None while it is put away."""

    texture: Gray
    width: float
    height: float
    squares: tuple[int, int]
    square: float
    marker: float
    dictionary: str


class SimCamera(CameraDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        camera: CameraModel,
        board: Board,
        *,
        fps: float = 10.0,
        noise: float = 1.0,
        blur: float = 0.0,
        seed: int | None = None,
        cell: CellClient | None = None,
        tags: str = "4x4_50",
    ) -> None:
        info = CameraInfo(
            model="simulated camera", width=camera.width, height=camera.height, fps=fps
        )
        super().__init__(identity, info)
        self.camera, self.board = camera, board
        self.noise, self.blur = noise, blur
        self.board_pose: np.ndarray | None = None
        # The robot's cell in view (its parts and flange tag, asked at every frame).
        self.cell, self.tags = cell, tags
        self.scene: dict[str, Any] | None = None
        self._renderer: Renderer | None = None
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()  # renders one at a time (the ray table is shared)
        self._period = 1.0 / fps
        self._last = 0.0
        self.frames = 0
        self.last_frame: float | None = None

    async def start(self) -> None:
        # The rays of every pixel, found once (seconds at full size): before the first frame.
        self._renderer = await asyncio.to_thread(Renderer, self.camera)

    def state(self) -> CameraState:
        return CameraState(
            seqno=self.frames,
            ts=time.time(),
            connected=self._renderer is not None,
            frames=self.frames,
            last_frame=self.last_frame,
            error="" if self._renderer is not None else "starting",
        )

    def put_board(self, pose: np.ndarray | None) -> None:
        self.board_pose = None if pose is None else np.array(pose, dtype=float)

    async def capture(self, request: CaptureRequest) -> Image:
        if self._renderer is None:
            raise DeviceError("the camera is still starting", code="not_ready", status=503)
        # Frames come at the camera's rate, however fast they are asked for.
        wait = self._last + self._period - time.monotonic()
        if wait > 0:
            await asyncio.sleep(wait)
        self._last = time.monotonic()
        taken = time.time()
        scene = await self.cell.ask("scene") if self.cell is not None else None
        self.scene = scene if scene is not None and "error" not in scene else None
        pixels = await asyncio.to_thread(self._render, self.scene)
        self.frames += 1
        self.last_frame = taken
        return encoded(pixels, request, self.frames, taken)

    def _render(self, scene: dict[str, Any] | None) -> Gray:
        assert self._renderer is not None
        targets = cell_targets(scene, self.tags) if scene is not None else []
        board, pose = self.board, self.board_pose
        if pose is not None:
            targets.append(Target(board.texture, board.width, board.height, pose))
        with self._lock:
            return self._renderer.render(targets, noise=self.noise, blur=self.blur, rng=self._rng)
