"""The rr-camera driver (plugins/robotraconteur) against an RR standard camera
(tests/support/rr_sim_camera.py) over rr+tcp on loopback, RR's discovery off: the camera's
own calibration as its intrinsics, frames as the camera gave them (PNG: the very pixels), a
frame taken after it was asked for, and the camera gone a fault said in the state and by
captures until it is back."""

from __future__ import annotations

import asyncio
import base64
import time
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from openpendant.plugins.robotraconteur.camera_driver import RRCamera
from openpendant.plugins.robotraconteur.entry import RRCameraOptions, create_camera
from openpendant.runtime.bench.harness.processes import wait_for
from openpendant.runtime.interfaces.camera import CaptureRequest, Image
from openpendant.runtime.kit.errors import DeviceError
from tests.support.rr_service import RRService
from tests.support.rr_sim_camera import CALIBRATION, HEIGHT, WIDTH, picture

# No real-time margins here (seconds-long waits): beside the real-time tests, at nice 19.
pytestmark = pytest.mark.concurrent


class RRCameraProcess(RRService):
    def __init__(self, port: int | None = None) -> None:
        super().__init__("rr_sim_camera", "camera", port=port)


@pytest.fixture
def camera_process() -> Iterator[list[RRCameraProcess]]:
    """The camera (a list: a test may start it again on its port)."""
    started = [RRCameraProcess()]
    yield started
    for each in started:
        each.kill()


def decoded(image: Image) -> np.ndarray:
    pixels = cv2.imdecode(np.frombuffer(base64.b64decode(image.data), np.uint8), cv2.IMREAD_COLOR)
    assert pixels is not None
    return pixels


def number_of(pixels: np.ndarray) -> int:
    return int(pixels[0, 0, 0]) + 256 * int(pixels[0, 0, 1])


def test_frames_calibration_and_a_lost_camera(camera_process: list[RRCameraProcess]) -> None:
    served = camera_process[0]
    camera = create_camera("cam", "rr-cam-1", RRCameraOptions(url=served.url, fps=20))
    assert isinstance(camera, RRCamera)
    loop = asyncio.new_event_loop()
    try:
        assert (camera.info.width, camera.info.height) == (WIDTH, HEIGHT)
        assert camera.info.model == "RR test camera"
        intrinsics = camera.info.intrinsics
        assert intrinsics is not None
        assert (intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy) == (
            CALIBRATION["fx"],
            CALIBRATION["fy"],
            CALIBRATION["cx"],
            CALIBRATION["cy"],
        )
        assert intrinsics.distortion == [CALIBRATION["k1"], 0.0, 0.0, CALIBRATION["p2"], 0.0]
        loop.run_until_complete(camera.start())

        first = decoded(loop.run_until_complete(camera.capture(CaptureRequest(encoding="png"))))
        assert np.array_equal(first, picture(number_of(first)))  # the camera's very pixels
        asked = time.time()
        later = loop.run_until_complete(camera.capture(CaptureRequest(encoding="png")))
        assert later.ts >= asked and number_of(decoded(later)) > number_of(first)
        jpeg = loop.run_until_complete(camera.capture(CaptureRequest(encoding="jpeg")))
        assert (jpeg.width, jpeg.height, jpeg.encoding) == (WIDTH, HEIGHT, "jpeg")

        served.kill()
        wait_for(lambda: not camera.state().connected, 5, what="the loss said")
        assert camera.state().error
        with pytest.raises(DeviceError) as refused:
            loop.run_until_complete(camera.capture(CaptureRequest()))
        assert refused.value.code == "camera_lost"

        camera_process.append(RRCameraProcess(served.port))  # back, on the same port
        wait_for(lambda: camera.state().connected, 10, what="connected again")
        again = loop.run_until_complete(camera.capture(CaptureRequest(encoding="png")))
        assert np.array_equal(decoded(again), picture(number_of(decoded(again))))
    finally:
        loop.run_until_complete(camera.shutdown())
        loop.close()
