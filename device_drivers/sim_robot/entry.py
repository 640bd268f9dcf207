"""The simulated robot as the driver host starts it (`openpendant driver sim-robot`)."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from device_drivers.sim_robot.driver import SimRobot
from device_drivers.sim_robot.routes import sim_router
from runtime.interfaces.device import DeviceIdentity
from runtime.robotics.robot_info import available_models, load_robot_info


class SimRobotOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    model: str = Field(
        default="ur5",
        description=f"robot model ({', '.join(available_models())}) or a robot-info YAML",
    )

    def default_name(self) -> str:
        return f"sim-{Path(self.model).stem}"


def create(name: str, uuid: str, options: SimRobotOptions) -> SimRobot:
    info = load_robot_info(options.model)
    return SimRobot(DeviceIdentity(uuid=uuid, kind="robot", model=info.model, name=name), info)


def routes(driver: SimRobot) -> APIRouter:
    return sim_router(driver)
