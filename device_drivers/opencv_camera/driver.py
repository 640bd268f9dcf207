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

from openpendant.device_drivers.opencv_camera.sources import (
    Settings,
    SourceLost,
    open_source,
    paced,
)
from openpendant.runtime.drivers.latest_frame import LatestFrameCamera
from openpendant.runtime.interfaces.camera import CameraInfo
from openpendant.runtime.interfaces.device import DeviceIdentity

log = logging.getLogger(__name__)
REPLAY_FPS = 10.0  # a file or folder that does not say its rate


class OpenCVCamera(LatestFrameCamera):
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
        super().__init__(identity, info, source)
        self.source, self.settings, self.loop, self.reconnect = source, settings, loop, reconnect
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
            self._answering()
            log.info("camera %s open", self.source)
            last = 0.0
            try:
                while not self._stop.is_set():
                    if replay:
                        time.sleep(paced(last, fps))
                        last = time.monotonic()
                    self._keep(source.read(), time.time())
            except SourceLost as exc:
                self._lost(str(exc))
            except Exception as exc:  # a corrupt stream must not end the reader for good
                log.exception("camera %s failed", self.source)
                self._lost(f"{type(exc).__name__}: {exc}")
                self._stop.wait(self.reconnect)
            finally:
                source.close()
