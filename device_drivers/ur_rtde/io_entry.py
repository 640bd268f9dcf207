"""A UR controller's I/O as the driver host starts it (`openpendant driver ur-io --address
HOST`), beside the arm's own driver (`ur-rtde`) for the same controller."""

from __future__ import annotations

from pydantic import Field

from openpendant.device_drivers.ur_rtde.entry import ControllerOptions
from openpendant.device_drivers.ur_rtde.io_driver import Domain, URIODriver
from openpendant.runtime.interfaces.device import DeviceIdentity


class URIOOptions(ControllerOptions):
    analog_inputs: Domain = Field(
        default="voltage", description="the domain the controller's I/O setup gives AI0/AI1"
    )
    analog_outputs: Domain = Field(
        default="voltage", description="the domain AO0/AO1 are written in (0-10 V or 4-20 mA)"
    )
    frequency: float = Field(default=125.0, gt=0, le=500, description="RTDE Hz")
    poll_hz: float = Field(default=100.0, gt=0, le=500, description="reads per second")

    def default_name(self) -> str:
        return "ur_io"


def create(name: str, uuid: str, options: URIOOptions) -> URIODriver:
    host = options.host()
    identity = DeviceIdentity(
        uuid=uuid, kind="io", model="Universal Robots controller I/O", name=name
    )
    return URIODriver(
        identity,
        host,
        analog_inputs=options.analog_inputs,
        analog_outputs=options.analog_outputs,
        frequency=options.frequency,
        poll_hz=options.poll_hz,
    )
