"""Any Robot Raconteur standard camera (`com.robotraconteur.imaging.Camera`) as an
OpenPendant camera. A reader thread asks the camera for a frame (`capture_frame`) at the
frame rate and keeps the newest; a capture returns a frame taken after it was asked for. The
camera's own calibration (its `camera_info`), where it has one, is its intrinsics. A camera
that stops answering is a fault, said in the state; the reader connects again every
`reconnect` seconds."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from typing import Any

import cv2
import numpy as np
from RobotRaconteurCompanion.Util.ImageUtil import ImageUtil

from openpendant.plugins.robotraconteur.node import Node
from openpendant.runtime.drivers.latest_frame import LatestFrameCamera
from openpendant.runtime.interfaces.camera import CameraInfo, Intrinsics
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import DeviceError

log = logging.getLogger(__name__)
DISTORTION = ("k1", "k2", "p1", "p2", "k3")  # OpenCV's order


def _named(array: Any, field: str) -> float:
    """A field of one of RR's named arrays (numpy records: the fields by name)."""
    return float(np.asarray(array[field]).flat[0])


def intrinsics_of(camera_info: Any) -> Intrinsics | None:
    """The camera's calibration as OpenCV's pinhole model, or None where it has none."""
    calibration = getattr(camera_info, "calibration", None)
    if calibration is None or calibration.K is None or calibration.image_size is None:
        return None
    k = np.asarray(calibration.K, dtype=float).reshape(3, 3)
    size = calibration.image_size
    width, height = int(_named(size, "width")), int(_named(size, "height"))
    if k[0, 0] <= 0 or k[1, 1] <= 0 or width <= 0 or height <= 0:
        return None
    # A varvalue: RR's plumb bob model (k1, k2, p1, p2, k3) or another.
    distortion = getattr(calibration.distortion_info, "data", None)
    return Intrinsics(
        width=width,
        height=height,
        fx=float(k[0, 0]),
        fy=float(k[1, 1]),
        cx=float(k[0, 2]),
        cy=float(k[1, 2]),
        distortion=[float(getattr(distortion, c, 0.0) or 0.0) for c in DISTORTION]
        if distortion is not None
        else [],
    )


def pixels_of(array: np.ndarray) -> np.ndarray:
    """What OpenCV encodes: 8-bit grey or BGR."""
    if array.dtype != np.uint8:
        raise DeviceError(
            f"the camera's {array.dtype} images cannot be shown", code="camera_format"
        )
    if array.ndim == 3 and array.shape[2] == 4:
        return cv2.cvtColor(array, cv2.COLOR_BGRA2BGR)
    return array


class RRCamera(LatestFrameCamera):
    def __init__(
        self,
        identity: DeviceIdentity,
        info: CameraInfo,
        url: str,
        *,
        node: Node,
        client: Any,
        reconnect: float = 1.0,
    ) -> None:
        super().__init__(identity, info, url)
        self.url, self.node, self.reconnect = url, node, reconnect
        self.client: Any = client
        if client is not None:
            self._answering()
        else:
            self.error = "not connected yet"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    async def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._read, name="rr-camera", daemon=True)
        self._thread.start()

    async def shutdown(self) -> None:
        self._stop.set()
        with self.changed:
            self.changed.notify_all()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 5.0)
        self.node.close()

    # The reader -------------------------------------------------------------------------------

    def _read(self) -> None:
        period = 1.0 / self.info.fps
        while not self._stop.is_set():
            client = self.client
            if client is None:
                try:
                    client = self.client = self.node.connect(self.url)
                except Exception as exc:
                    self._lost(f"cannot reach the camera at {self.url}: {exc}")
                    self._stop.wait(self.reconnect)
                    continue
                self._answering()
                log.info("camera %s connected", self.url)
            images = ImageUtil(self.node.node, client)
            try:
                while not self._stop.is_set():
                    began, asked = time.monotonic(), time.time()
                    pixels = pixels_of(images.image_to_array(client.capture_frame()))
                    # Taken no earlier than it was asked for: a frame asked for before a
                    # capture request was, though it came after, may show the world from
                    # before that request.
                    self._keep(pixels, asked)
                    self._stop.wait(max(0.0, period - (time.monotonic() - began)))
            except Exception as exc:
                self._lost(f"{type(exc).__name__}: {exc}")
                self.client = None
                with contextlib.suppress(Exception):  # the old connection, if it is still open
                    self.node.node.DisconnectService(client)
                self._stop.wait(self.reconnect)
