"""The OpenCV camera as the driver host starts it (`openpendant driver opencv-camera
--source 0`): a USB camera by its index, an RTSP/HTTP stream by its URL, a video file or a
folder of images (replayed in a loop at `--fps`)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from openpendant.device_drivers.opencv_camera.driver import OpenCVCamera
from openpendant.runtime.interfaces.device import DeviceIdentity


class OpenCVCameraOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    source: str = Field(
        min_length=1,
        max_length=512,
        description="a camera index (0), a stream URL, a video file or an image folder",
    )
    width: int | None = Field(default=None, ge=16, le=8192, description="image width asked (px)")
    height: int | None = Field(default=None, ge=16, le=8192, description="image height (px)")
    fps: float | None = Field(default=None, gt=0, le=240, description="frames a second")
    exposure: float | None = Field(
        default=None, description="manual exposure, in the camera's own unit (unset: automatic)"
    )
    focus: float | None = Field(
        default=None, ge=0, description="manual focus, in the camera's unit (unset: autofocus)"
    )
    loop: bool = Field(default=True, description="replay a file or folder again at its end")
    reconnect: float = Field(
        default=1.0, gt=0.05, le=60, description="seconds between attempts to reopen a lost camera"
    )

    def default_name(self) -> str:
        return "camera"


def create(name: str, uuid: str, options: OpenCVCameraOptions) -> OpenCVCamera:
    identity = DeviceIdentity(uuid=uuid, kind="camera", model="OpenCV camera", name=name)
    return OpenCVCamera(
        identity, options.source, options, loop=options.loop, reconnect=options.reconnect
    )
