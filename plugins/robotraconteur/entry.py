"""An RR standard robot as the driver host starts it
(`openpendant driver rr-robot --url rr+tcp://HOST:PORT?service=robot`)."""

from __future__ import annotations

import os

from pydantic import BaseModel, ConfigDict, Field

from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import InvalidValue

PASSWORD_ENV = "OPENPENDANT_RR_PASSWORD"


class RRRobotOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    url: str = Field(
        default="",
        max_length=2000,
        pattern=r"^(rr\+tcp|rrs\+tcp|rr\+ws|rrs\+ws)://",
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
    # RR is imported only here, when such a driver runs (the `rr` extra).
    try:
        from openpendant.plugins.robotraconteur.node import Node
        from openpendant.plugins.robotraconteur.robot_driver import RRRobotDriver
        from openpendant.plugins.robotraconteur.robot_info import robot_info_of
        from openpendant.plugins.robotraconteur.robot_link import RRLink
    except ModuleNotFoundError as exc:
        raise InvalidValue(
            f"rr-robot needs Robot Raconteur ({exc.name} is missing): pip install 'openpendant[rr]'"
        ) from exc

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
