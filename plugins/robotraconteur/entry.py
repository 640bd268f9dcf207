"""RR standard robots, cameras and tools as the driver host starts them
(`openpendant driver rr-robot --url 'rr+tcp://HOST:PORT?service=robot'`, `driver rr-camera
--url 'rr+tcp://HOST:PORT?service=camera'`, `driver rr-tool --url
'rr+tcp://HOST:PORT?service=tool'`). RR is imported only when such a driver runs (the `rr`
extra)."""

from __future__ import annotations

import os
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import InvalidValue

PASSWORD_ENV = "OPENPENDANT_RR_PASSWORD"
URL_PATTERN = r"^(rr\+tcp|rrs\+tcp|rr\+ws|rrs\+ws)://"


def without_rr(exc: ModuleNotFoundError) -> InvalidValue:
    return InvalidValue(
        f"this driver needs Robot Raconteur ({exc.name} is missing): pip install 'openpendant[rr]'"
    )


def model_name(device_info: Any, otherwise: str) -> str:
    """A device's model as its RR device info names it (else the device's own name)."""
    for part in ("model", "device"):
        name = getattr(getattr(device_info, part, None), "name", None)
        if name:
            return str(name)
    return otherwise


class RRRobotOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    url: str = Field(
        default="",
        max_length=2000,
        pattern=URL_PATTERN,
        description="the robot's RR URL, e.g. rr+tcp://10.0.0.5:52511?service=robot",
    )
    user: str | None = Field(
        default=None, max_length=64, description=f"RR user name (its password: ${PASSWORD_ENV})"
    )
    rate_hz: float = Field(default=100.0, ge=10, le=1000, description="the robot's state rate")

    def default_name(self) -> str:
        return "rr_robot"


def create(name: str, uuid: str, options: RRRobotOptions) -> object:
    if not options.url:
        raise InvalidValue("--url is the robot's RR URL (rr+tcp://HOST:PORT?service=robot)")
    try:
        from openpendant.plugins.robotraconteur.node import Node
        from openpendant.plugins.robotraconteur.robot_driver import RRRobotDriver
        from openpendant.plugins.robotraconteur.robot_info import robot_info_of
        from openpendant.plugins.robotraconteur.robot_link import RRLink
    except ModuleNotFoundError as exc:
        raise without_rr(exc) from exc

    password = os.environ.get(PASSWORD_ENV)
    node = Node()
    try:
        link = RRLink(node, options.url, options.user, password)
        info = robot_info_of(link.client.robot_info, node.node)
    except Exception as exc:
        node.close()
        raise InvalidValue(f"cannot read the robot at {options.url}: {exc}") from exc
    identity = DeviceIdentity(uuid=uuid, kind="robot", model=info.model, name=name)
    return RRRobotDriver(
        identity,
        info,
        options.url,
        node=node,
        link=link,
        user=options.user,
        password=password,
        period=1.0 / options.rate_hz,
    )


class RRCameraOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    url: str = Field(
        default="",
        max_length=2000,
        pattern=URL_PATTERN,
        description="the camera's RR URL, e.g. rr+tcp://10.0.0.6:59823?service=camera",
    )
    fps: float = Field(default=10.0, gt=0, le=60, description="frames a second asked for")
    reconnect: float = Field(
        default=1.0, gt=0.05, le=60, description="seconds between attempts to reach a lost camera"
    )

    def default_name(self) -> str:
        return "camera"


def create_camera(name: str, uuid: str, options: RRCameraOptions) -> object:
    if not options.url:
        raise InvalidValue("--url is the camera's RR URL (rr+tcp://HOST:PORT?service=camera)")
    try:
        from RobotRaconteurCompanion.Util.ImageUtil import ImageUtil

        from openpendant.plugins.robotraconteur.camera_driver import (
            RRCamera,
            intrinsics_of,
            pixels_of,
        )
        from openpendant.plugins.robotraconteur.node import Node
    except ModuleNotFoundError as exc:
        raise without_rr(exc) from exc
    from openpendant.runtime.interfaces.camera import CameraInfo

    node = Node()
    try:
        client = node.connect(options.url)
        camera_info = client.camera_info
        first = pixels_of(ImageUtil(node.node, client).image_to_array(client.capture_frame()))
        model = model_name(camera_info.device_info, "RR camera")
        height, width = first.shape[:2]
        info = CameraInfo(
            model=model[:64],
            width=width,
            height=height,
            fps=options.fps,
            intrinsics=intrinsics_of(camera_info),
        )
    except Exception as exc:
        node.close()
        raise InvalidValue(f"cannot read the camera at {options.url}: {exc}") from exc
    identity = DeviceIdentity(uuid=uuid, kind="camera", model=info.model, name=name)
    return RRCamera(
        identity, info, options.url, node=node, client=client, reconnect=options.reconnect
    )


class RRToolOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    url: str = Field(
        default="",
        max_length=2000,
        pattern=URL_PATTERN,
        description="the tool's RR URL, e.g. rr+tcp://10.0.0.7:52522?service=tool",
    )
    reconnect: float = Field(
        default=1.0, gt=0.05, le=60, description="seconds between attempts to reach a lost tool"
    )

    def default_name(self) -> str:
        return "gripper"


def create_tool(name: str, uuid: str, options: RRToolOptions) -> object:
    if not options.url:
        raise InvalidValue("--url is the tool's RR URL (rr+tcp://HOST:PORT?service=tool)")
    try:
        from openpendant.plugins.robotraconteur.node import Node
        from openpendant.plugins.robotraconteur.tool_driver import RRTool, tool_range_of
    except ModuleNotFoundError as exc:
        raise without_rr(exc) from exc
    from openpendant.runtime.interfaces.gripper import GripperInfo

    node = Node()
    try:
        client = node.connect(options.url)
        tool_info = client.tool_info
        tool_range = tool_range_of(tool_info)
        model = model_name(tool_info.device_info, "RR tool")
        capabilities = ["object_detection"]
        if tool_range.can("continuous_command"):
            capabilities.insert(0, "position")
        info = GripperInfo(model=model[:64], stroke=tool_range.stroke, capabilities=capabilities)
    except Exception as exc:
        node.close()
        raise InvalidValue(f"cannot read the tool at {options.url}: {exc}") from exc
    identity = DeviceIdentity(uuid=uuid, kind="gripper", model=info.model, name=name)
    url, reconnect = options.url, options.reconnect
    return RRTool(identity, info, tool_range, url, node=node, client=client, reconnect=reconnect)
