"""A Robot Raconteur standard camera (`com.robotraconteur.imaging.Camera`) for the RR tests:
`python -m tests.support.rr_sim_camera PORT [board]` serves it on 127.0.0.1:PORT as service
`camera` and prints `READY`. Each `capture_frame` is `picture(n)` for the n-th frame
(colour, BGR, 320x240), and its `camera_info` carries a calibration (`CALIBRATION`).

With `board`: the simulated camera's picture instead (device_drivers/sim_camera: 1280x800,
grey, a ChArUco board of 50 mm squares where `setf_param("board", pose as JSON)` puts it),
and no calibration; `getf_param("truth")` says, as JSON, the camera model it renders with."""

from __future__ import annotations

import asyncio
import json
import signal
import sys
import threading
from typing import Any

import numpy as np
import RobotRaconteur as RR
from RobotRaconteurCompanion.Util.ImageUtil import ImageUtil
from RobotRaconteurCompanion.Util.InfoFileLoader import InfoFileLoader
from scipy.spatial.transform import Rotation

from openpendant.device_drivers.sim_camera.driver import SimCamera as RenderedCamera
from openpendant.device_drivers.sim_camera.entry import SimCameraOptions, create
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


class BoardCamera(SimCamera):
    """The simulated camera's renders of its ChArUco board, wherever the test puts it."""

    def __init__(self, node: Any, info: Any) -> None:
        super().__init__(node, info)
        options = SimCameraOptions(noise=1.0, fps=20, square=0.05, marker=0.037)
        rendered = create("rr-board-camera", "rr-board-camera", options)
        assert isinstance(rendered, RenderedCamera)
        asyncio.run(rendered.start())  # the ray table, before the first frame
        self.rendered = rendered

    def capture_frame(self) -> Any:
        return self._images.array_to_image(self.rendered._render(None), "mono8")

    def setf_param(self, name: str, value: Any) -> None:
        if name != "board":
            raise RR.InvalidArgumentException(f"no parameter {name!r}")
        pose = json.loads(value.data)
        if pose is None:
            self.rendered.put_board(None)
            return
        matrix = np.eye(4)
        matrix[:3, :3] = Rotation.from_quat(pose["orientation"]).as_matrix()
        matrix[:3, 3] = pose["position"]
        self.rendered.put_board(matrix)

    def getf_param(self, name: str) -> Any:
        if name != "truth":
            raise RR.InvalidArgumentException(f"no parameter {name!r}")
        camera = self.rendered.camera
        pose = camera.pose
        truth = {
            "width": camera.width,
            "height": camera.height,
            "fx": camera.fx,
            "fy": camera.fy,
            "cx": camera.cx,
            "cy": camera.cy,
            "distortion": camera.coefficients.tolist(),
            "pose": {
                "position": pose[:3, 3].tolist(),
                "orientation": Rotation.from_matrix(pose[:3, :3]).as_quat().tolist(),
            },
        }
        return RR.VarValue(json.dumps(truth), "string")


def main(port: int, board: bool) -> None:
    node = Node("openpendant_rr_sim_camera", serve_port=port, localhost_only=True)
    described = {"device_info": INFO["device_info"]} if board else INFO
    info, _ = InfoFileLoader(node.node).LoadInfoFileFromDict(
        described, "com.robotraconteur.imaging.camerainfo.CameraInfo", "device"
    )
    camera = BoardCamera(node.node, info) if board else SimCamera(node.node, info)
    node.node.RegisterService("camera", CAMERA_TYPE, camera)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    print("READY", flush=True)
    done.wait()
    node.close()


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2:] == ["board"])
