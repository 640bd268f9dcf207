"""A Robot Raconteur standard camera (`com.robotraconteur.imaging.Camera`) for the RR tests:
`python -m tests.support.rr_sim_camera PORT` serves it on 127.0.0.1:PORT as service
`camera` and prints `READY`. Each `capture_frame` is `picture(n)` for the n-th frame
(colour, BGR, 320x240), and its `camera_info` carries a calibration (`CALIBRATION`)."""

from __future__ import annotations

import signal
import sys
import threading
from typing import Any

import numpy as np
from RobotRaconteurCompanion.Util.ImageUtil import ImageUtil
from RobotRaconteurCompanion.Util.InfoFileLoader import InfoFileLoader

from openpendant.plugins.robotraconteur.node import Node

WIDTH, HEIGHT = 320, 240
CALIBRATION = {"fx": 300.0, "fy": 310.0, "cx": 161.0, "cy": 119.0, "k1": -0.1, "p2": 0.002}
CAMERA_TYPE = "com.robotraconteur.imaging.Camera"
INFO = {
    "device_info": {
        "device": {"name": "rr_sim_camera", "uuid": "3b9e7c1a-5d2f-4a6b-9c8e-1f0a2b3c4d5e"},
        "model": {"name": "RR test camera", "uuid": "7d1c2b3a-4e5f-4a6b-8c9d-0e1f2a3b4c5d"},
        "implemented_types": [CAMERA_TYPE],
    },
    "calibration": {
        "image_size": {"width": WIDTH, "height": HEIGHT},
        "K": [
            [CALIBRATION["fx"], 0.0, CALIBRATION["cx"]],
            [0.0, CALIBRATION["fy"], CALIBRATION["cy"]],
            [0.0, 0.0, 1.0],
        ],
        "distortion_info": {
            "k1": CALIBRATION["k1"],
            "k2": 0.0,
            "p1": 0.0,
            "p2": CALIBRATION["p2"],
            "k3": 0.0,
        },
    },
}


def picture(number: int) -> np.ndarray:
    """A colour picture that tells its frame number apart (its first row's first pixels)."""
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    image = np.stack([xx % 256, yy % 256, ((xx // 20 + yy // 20) % 2) * 200], axis=2)
    image = image.astype(np.uint8)
    image[0, :4] = [number % 256, number // 256 % 256, 7]
    return image


class SimCamera:
    def __init__(self, node: Any, info: Any) -> None:
        self._info = info
        self._images = ImageUtil(node)
        self._number = 0
        self._lock = threading.Lock()

    @property
    def device_info(self) -> Any:
        return self._info.device_info

    @property
    def camera_info(self) -> Any:
        return self._info

    @property
    def capabilities(self) -> int:
        return 0x1  # software_capture

    def capture_frame(self) -> Any:
        with self._lock:
            self._number += 1
            number = self._number
        return self._images.array_to_image(picture(number), "bgr888")


def main(port: int) -> None:
    node = Node("openpendant_rr_sim_camera", serve_port=port, localhost_only=True)
    info, _ = InfoFileLoader(node.node).LoadInfoFileFromDict(
        INFO, "com.robotraconteur.imaging.camerainfo.CameraInfo", "device"
    )
    node.node.RegisterService("camera", CAMERA_TYPE, SimCamera(node.node, info))
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    print("READY", flush=True)
    done.wait()
    node.close()


if __name__ == "__main__":
    main(int(sys.argv[1]))
