"""The simulated robot as the driver host starts it (`openpendant driver sim-robot`)."""

from __future__ import annotations

import os
from pathlib import Path

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from openpendant.device_drivers.sim_robot.driver import SimRobot
from openpendant.device_drivers.sim_robot.routes import sim_router
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.robotics.robot_info import available_models, load_robot_info

# Every simulated robot started with this in its environment runs its trajectories this many
# times faster than real time (the test suite's, for tests that only need moves to finish).
TIME_SCALE_ENV = "OPENPENDANT_SIM_TIME_SCALE"


def default_time_scale() -> int:
    return int(os.environ.get(TIME_SCALE_ENV, "1"))


class SimRobotOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")

    model: str = Field(
        default="ur5",
        description=f"robot model ({', '.join(available_models())}) or a robot-info YAML",
    )
    time_scale: int = Field(
        default_factory=default_time_scale,
        ge=1,
        le=50,
        description=(
            "simulated seconds per second while a trajectory runs (1: real time); jogs and "
            f"streamed commands always run in real time; {TIME_SCALE_ENV} sets the default"
        ),
    )

    def default_name(self) -> str:
        return f"sim-{Path(self.model).stem}"


def create(name: str, uuid: str, options: SimRobotOptions) -> SimRobot:
    info = load_robot_info(options.model)
    identity = DeviceIdentity(uuid=uuid, kind="robot", model=info.model, name=name)
    return SimRobot(identity, info, time_scale=options.time_scale)


def routes(driver: SimRobot) -> APIRouter:
    return sim_router(driver)
