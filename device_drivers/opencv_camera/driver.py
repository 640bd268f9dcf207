"""A camera OpenCV opens, as the standard camera. A reader thread takes every frame the
source gives (a replayed file or folder at its frame rate) and keeps the newest; a capture
returns a frame taken after it was asked for. A source that stops answering (unplugged,
stream down, file gone) is a fault, said in the state; the reader opens it again every
`reconnect` seconds until it answers."""

from __future__ import annotations

import asyncio
import logging
import threading
import time

import numpy as np

from openpendant.device_drivers.opencv_camera.sources import (
    Settings,
    SourceLost,
    open_source,
    paced,
)
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
REPLAY_FPS = 10.0  # a file or folder that does not say its rate


class OpenCVCamera(CameraDriver):
    def __init__(
        self,
        identity: DeviceIdentity,
        source: str,
        settings: Settings,
        *,
        loop: bool = True,
        reconnect: float = 1.0,
    ) -> None:
        info = CameraInfo(
            model=f"OpenCV camera ({source})",
            width=settings.width or 640,
            height=settings.height or 480,
            fps=settings.fps or REPLAY_FPS,
        )
        super().__init__(identity, info)
        self.source, self.settings, self.loop, self.reconnect = source, settings, loop, reconnect
        self.changed = threading.Condition()
        self.latest: np.ndarray | None = None
        self.latest_at = 0.0  # when the newest frame was taken (time.time())
        self.frames = 0
        self.connected = False
        self.error = "starting"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    async def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._read, name="camera-reader", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        self._stop.set()
        with self.changed:
            self.changed.notify_all()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 5.0)

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
                if not self.connected and self.error != "starting":
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

    # The reader -------------------------------------------------------------------------------

    def _read(self) -> None:
        while not self._stop.is_set():
            source = open_source(self.source, self.settings, self.loop)
            try:
                source.open()
            except SourceLost as exc:
                self._lost(str(exc))
                self._stop.wait(self.reconnect)
                continue
            fps = self.settings.fps or source.native_fps() or REPLAY_FPS
            replay = source.replays()
            with self.changed:
                self.connected, self.error = True, ""
                self.changed.notify_all()
            log.info("camera %s open", self.source)
            last = 0.0
            try:
                while not self._stop.is_set():
                    if replay:
                        time.sleep(paced(last, fps))
                        last = time.monotonic()
                    frame = source.read()
                    with self.changed:
                        self.latest, self.latest_at = frame, time.time()
                        self.frames += 1
                        self.changed.notify_all()
            except SourceLost as exc:
                self._lost(str(exc))
            except Exception as exc:  # a corrupt stream must not end the reader for good
                log.exception("camera %s failed", self.source)
                self._lost(f"{type(exc).__name__}: {exc}")
                self._stop.wait(self.reconnect)
            finally:
                source.close()

    def _lost(self, why: str) -> None:
        with self.changed:
            if self.connected or self.error != why:
                log.warning("camera %s: %s", self.source, why)
            self.connected, self.error = False, why
            self.changed.notify_all()
