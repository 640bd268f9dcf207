"""A camera whose reader thread keeps the newest frame its source gave: a capture returns a
frame taken after it was asked for, and a source that stops answering is a fault, said in
the state and by refused captures, until the reader has it again. The OpenCV and Robot
Raconteur cameras are this, each with a reader of its own."""

from __future__ import annotations

import asyncio
import logging
import threading
import time

import numpy as np

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

log = logging.getLogger(__name__)
STARTING = "starting"


class LatestFrameCamera(CameraDriver):
    def __init__(self, identity: DeviceIdentity, info: CameraInfo, where: str) -> None:
        """`where`: the source, as the log names it."""
        super().__init__(identity, info)
        self.where = where
        self.changed = threading.Condition()
        self.latest: np.ndarray | None = None
        self.latest_at = 0.0  # when the newest frame was taken (time.time())
        self.frames = 0
        self.connected = False
        self.error = STARTING

    def state(self) -> CameraState:
        with self.changed:
            return CameraState(
                seqno=self.frames,
                ts=time.time(),
                connected=self.connected,
                frames=self.frames,
                last_frame=self.latest_at or None,
                error=self.error,
            )

    async def capture(self, request: CaptureRequest) -> Image:
        return (await self.frame(request)).image()

    async def frame(self, request: CaptureRequest) -> Frame:
        asked = time.time()
        pixels, taken, number = await asyncio.to_thread(self._frame_after, asked)
        return encoded_frame(pixels, request, number, taken)

    def _frame_after(self, asked: float) -> tuple[np.ndarray, float, int]:
        timeout = max(3.0 / self.info.fps, 2.0)
        deadline = time.monotonic() + timeout
        with self.changed:
            while self.latest is None or self.latest_at < asked:
                if not self.connected and self.error != STARTING:
                    raise DeviceError(
                        f"the camera is not answering: {self.error}", code="camera_lost", status=503
                    )
                left = deadline - time.monotonic()
                if left <= 0:
                    raise DeviceError(
                        f"no frame from the camera within {timeout:.1f} s",
                        code="camera_timeout",
                        status=504,
                    )
                self.changed.wait(left)
            return self.latest, self.latest_at, self.frames

    def _answering(self) -> None:
        with self.changed:
            self.connected, self.error = True, ""
            self.changed.notify_all()

    def _keep(self, pixels: np.ndarray, taken: float) -> None:
        with self.changed:
            self.latest, self.latest_at = pixels, taken
            self.frames += 1
            self.changed.notify_all()

    def _lost(self, why: str) -> None:
        with self.changed:
            if self.connected or self.error != why:
                log.warning("camera %s: %s", self.where, why)
            self.connected, self.error = False, why
            self.changed.notify_all()
