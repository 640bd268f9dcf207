"""What a simulator has and a robot does not: the E-stop button, the key switch, faults on
demand, and a look inside the control loop."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, Response
from pydantic import Field

from openpendant.device_drivers.sim_cell.world import CellSetup, Frame, Part
from openpendant.device_drivers.sim_robot.driver import SimRobot
from openpendant.runtime.interfaces.common import Pose, Strict
from openpendant.runtime.interfaces.robot import OperationalMode, RobotState


class EstopRequest(Strict):
    engaged: bool


class FaultRequest(Strict):
    message: str = Field(default="simulated fault", max_length=200)


class DigitalInputRequest(Strict):
    value: bool


class OperationalModeRequest(Strict):
    mode: OperationalMode


class PlaceRequest(Strict):
    joints: list[float] = Field(min_length=1, max_length=16)


class TimeScaleRequest(Strict):
    scale: int = Field(ge=1, le=50)


class PushRequest(Strict):
    velocity: list[float] = Field(min_length=1, max_length=16)  # rad/s per joint


def sim_router(robot: SimRobot) -> APIRouter:
    router = APIRouter(prefix="/sim")

    @router.get("/cell/parts")
    async def parts(frame: Frame = "base") -> list[Part]:
        """Every part's true pose (held ones where the TCP carries them), in the robot's base
        frame or in the world."""
        return robot.world.snapshot(frame)

    @router.put("/cell")
    async def cell(body: CellSetup, frame: Frame = "base") -> list[Part]:
        """Lay out the table: the parts, the presence sensors, the flange's tag."""
        robot.world.replace(body, frame)
        return robot.world.snapshot(frame)

    @router.put("/base")
    async def base(body: Pose) -> dict[str, object]:
        """Where the robot truly stands in the world (the simulation's truth, which robot-origin
        calibration finds); the parts stay where they are in the world."""
        robot.world.move_base(body)
        return robot.world.scene()

    @router.get("/scene")
    async def scene() -> dict[str, object]:
        """In the world: the robot's true base, the parts, the flange's tag."""
        return robot.world.scene()

    @router.get("/cell/sensors")
    async def sensors() -> dict[str, bool]:
        return robot.world.sensed()

    @router.post("/estop")
    async def estop(body: EstopRequest) -> RobotState:
        robot.set_estop(body.engaged)
        return robot.state()

    @router.post("/fault")
    async def fault(body: FaultRequest) -> RobotState:
        robot.inject_fault(body.message)
        return robot.state()

    @router.put("/operational_mode")
    async def operational_mode(body: OperationalModeRequest) -> RobotState:
        robot.set_operational_mode(body.mode)
        return robot.state()

    @router.put("/joints")
    async def place(body: PlaceRequest) -> RobotState:
        """Put the standing arm at these joints at once: a test's set-up in no time, where
        a robot would have to be moved there."""
        robot.place(body.joints)
        return robot.state()

    @router.put("/hand")
    async def hand(body: PushRequest) -> RobotState:
        """A hand pushing the arm at these joint velocities (zero: let go): held free
        (freedrive) the arm goes where it takes it; servoed (a move, a jog) it is pushed off
        its setpoint and pulled back when let go; halted, the brakes hold it."""
        robot.push(body.velocity)
        return robot.state()

    @router.put("/time_scale")
    async def time_scale(body: TimeScaleRequest) -> dict[str, int]:
        """Trajectories played this many times faster than real time from the next control
        period on (streams and states stay in real time): a test's moves that only need to
        end, in less time."""
        with robot.lock:
            robot.time_scale = body.scale
        return {"time_scale": body.scale}

    @router.put("/digital_inputs/{index}")
    async def digital_input(index: int, body: DigitalInputRequest) -> RobotState:
        robot.set_digital_input(index, body.value)
        return robot.state()

    @router.get("/loop_stats")
    async def loop_stats() -> dict[str, Any]:
        with robot.lock:
            timeouts = robot.core.command_timeouts
        return {**robot.timer.stats(), "command_timeouts": timeouts}

    @router.delete("/loop_stats", status_code=204)
    async def reset_loop_stats() -> Response:
        """Start a fresh measurement window."""
        robot.timer.reset()
        return Response(status_code=204)

    @router.get("/setpoints")
    async def setpoints(
        after: int = 0, limit: Annotated[int, Query(ge=1, le=20000)] = 5000
    ) -> dict[str, Any]:
        """Every control-cycle setpoint after `after` still in the history buffer."""
        with robot.lock:
            samples = [s for s in robot.core.setpoints if s.seqno > after][:limit]
        return {
            "cycle": 0.002,
            "seqno": [s.seqno for s in samples],
            "t": [s.t for s in samples],
            "wall": [s.wall for s in samples],
            "position": [s.position.tolist() for s in samples],
            "velocity": [s.velocity.tolist() for s in samples],
            "acceleration": [s.acceleration.tolist() for s in samples],
        }

    return router
