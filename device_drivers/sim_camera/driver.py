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

from openpendant.device_drivers.sim_camera.optics import CameraModel, Gray, Renderer, Target
from openpendant.device_drivers.sim_camera.scene import cell_targets
from openpendant.device_drivers.sim_cell.link import CellClient
from openpendant.runtime.imaging.encoding import encoded_frame
from openpendant.runtime.interfaces.camera import (
    CameraDriver,
    CameraInfo,
    CameraState,
    CaptureRequest,
    Frame,
    Image,
)
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import DeviceError

CELL_WAIT = 30.0  # s the robot named by `cell` may take to come up (all start at once)
CELL_LOOK = 0.5  # s between looks for it


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
        cell_wait: float = CELL_WAIT,
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
        # A cell that never answered is a robot name that matches none (the camera would
        # draw an empty table): the camera starts first, so only after `cell_wait` is it
        # said, in its state and by refusing frames; found later, it is forgotten.
        self.cell_wait = cell_wait
        self.cell_seen = False
        self._looking_since = time.monotonic()
        self._looking: asyncio.Task[None] | None = None
        self._renderer: Renderer | None = None
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()  # renders one at a time (the ray table is shared)
        self._period = 1.0 / fps
        self._last = 0.0
        self.frames = 0
        self.last_frame: float | None = None

    async def start(self) -> None:
        # The rays of every pixel, found once (seconds at full size): before the first frame.
        self._looking_since = time.monotonic()
        if self.cell is not None:
            self._looking = asyncio.create_task(self._look_for_cell(self.cell))
        self._renderer = await asyncio.to_thread(Renderer, self.camera)

    async def shutdown(self) -> None:
        if self._looking is not None:
            self._looking.cancel()

    async def _look_for_cell(self, cell: CellClient) -> None:
        while not self.cell_seen:
            if await cell.ask("parts") is not None:
                self.cell_seen = True
                return
            await asyncio.sleep(CELL_LOOK)

    def missing_cell(self) -> str:
        """Why the camera shows no cell, once the robot it names had time to come up."""
        if self.cell is None or self.cell_seen:
            return ""
        if time.monotonic() - self._looking_since < self.cell_wait:
            return ""
        return (
            f"no simulated robot named {self.cell.robot!r} answers on this computer: "
            f"--cell must name a running simulated robot (waited {self.cell_wait:.0f} s)"
        )

    def state(self) -> CameraState:
        return CameraState(
            seqno=self.frames,
            ts=time.time(),
            connected=self._renderer is not None,
            frames=self.frames,
            last_frame=self.last_frame,
            error="starting" if self._renderer is None else self.missing_cell(),
        )

    def put_board(self, pose: np.ndarray | None) -> None:
        self.board_pose = None if pose is None else np.array(pose, dtype=float)

    async def capture(self, request: CaptureRequest) -> Image:
        return (await self.frame(request)).image()

    async def frame(self, request: CaptureRequest) -> Frame:
        if self._renderer is None:
            raise DeviceError("the camera is still starting", code="not_ready", status=503)
        missing = self.missing_cell()
        if missing:
            raise DeviceError(missing, code="no_cell", status=409)
        # Frames come at the camera's rate, however fast they are asked for.
        wait = self._last + self._period - time.monotonic()
        if wait > 0:
            await asyncio.sleep(wait)
        self._last = time.monotonic()
        taken = time.time()
        scene = await self.cell.ask("scene") if self.cell is not None else None
        self.scene = scene if scene is not None and "error" not in scene else None
        self.cell_seen = self.cell_seen or scene is not None
        pixels = await asyncio.to_thread(self._render, self.scene)
        self.frames += 1
        self.last_frame = taken
        return encoded_frame(pixels, request, self.frames, taken)

    def _render(self, scene: dict[str, Any] | None) -> Gray:
        assert self._renderer is not None
        targets = cell_targets(scene, self.tags) if scene is not None else []
        board, pose = self.board, self.board_pose
        if pose is not None:
            targets.append(Target(board.texture, board.width, board.height, pose))
        with self._lock:
            return self._renderer.render(targets, noise=self.noise, blur=self.blur, rng=self._rng)
