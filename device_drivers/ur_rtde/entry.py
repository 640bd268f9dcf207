"""A UR arm as the driver host starts it (`openpendant driver ur-rtde --address HOST`)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from openpendant.device_drivers.ur_rtde.driver import URDriver
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.kit.errors import InvalidValue
from openpendant.runtime.robotics.robot_info import available_models, load_robot_info


class ControllerOptions(BaseModel):
    """Where the UR controller is: every driver of one (the arm's, its I/O's) needs it."""

    model_config = ConfigDict(extra="forbid")

    address: str = Field(default="", max_length=253, description="the controller's host name or IP")

    def host(self) -> str:
        if not self.address:
            raise InvalidValue("--address is the controller's host name or IP address")
        return self.address


class UROptions(ControllerOptions):
    model: str = Field(
        default="ur5e",
        description=f"robot-info ({', '.join(available_models())}) or a YAML; checked against "
        "the controller",
    )
    frequency: float = Field(default=-1.0, le=500, description="RTDE Hz (-1: the controller's)")
    watchdog_hz: float = Field(default=10.0, ge=1, le=125, description="stop below this rate")
    lookahead: float = Field(default=0.1, ge=0.03, le=0.2, description="servoJ lookahead (s)")
    gain: float = Field(default=300.0, ge=100, le=2000, description="servoJ gain")

    def default_name(self) -> str:
        return "ur"


def create(name: str, uuid: str, options: UROptions) -> URDriver:
    host = options.host()
    info = load_robot_info(options.model)
    identity = DeviceIdentity(uuid=uuid, kind="robot", model=info.model, name=name)
    return URDriver(
        identity,
        info,
        host,
        frequency=options.frequency,
        watchdog_hz=options.watchdog_hz,
        lookahead=options.lookahead,
        gain=options.gain,
    )
