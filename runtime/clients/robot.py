"""A service's robot: the standard robot interface over the device manager's one link to it.
Streamed commands (jog, velocity and position setpoints, mode changes) go in order on the
robot's session; the rest are calls. Whatever a service starts on a robot names the link
generation it began on; when that link is lost the next one refuses it, so it never
continues by itself."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from pydantic import BaseModel

from openpendant.runtime.clients.base import DeviceClient
from openpendant.runtime.interfaces.endpoints import stream_commands
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    DigitalOutputCommand,
    FreedriveCommand,
    JogJointCommand,
    JointTrajectory,
    PositionCommand,
    ProtectiveStopRequest,
    Robot,
    RobotDescription,
    RobotInfo,
    RobotState,
    SpeedRatioRequest,
    ToolCommand,
    ToolSetup,
    TrajectoryAccepted,
    TrajectoryStatus,
    VelocityCommand,
)
from openpendant.runtime.links.hub import DeviceView, LinkHub

# The message type of each streamable command body, as the interface declares it.
STREAM_TYPES: dict[type[BaseModel], str] = {
    ep.body: kind for kind, ep in stream_commands(Robot).items() if ep.body is not None
}


@dataclass(frozen=True)
class Halt:
    """Stop now (a streamed halt, on whatever session is live)."""

    tag: str | None = None


Streamed = (
    JogJointCommand
    | VelocityCommand
    | PositionCommand
    | FreedriveCommand
    | CommandModeRequest
    | Halt
)


class RobotClient(DeviceClient[RobotState], Robot):
    kind: ClassVar[str] = "robot"
    state_model = RobotState

    def __init__(self, hub: LinkHub, view: DeviceView) -> None:
        super().__init__(hub, view)
        self._info: RobotInfo | None = None
        self._info_source: dict[str, Any] | None = None
        # The mode this service last set, and on which link. Right after a halt the state
        # can still show the old mode, so the state alone cannot say if a switch is needed.
        self._mode: tuple[CommandMode, int] | None = None

    @property
    def info(self) -> RobotInfo:
        source = self.description
        if source is not self._info_source:
            self._info = RobotInfo.model_validate(source["info"])
            self._info_source = source
        assert self._info is not None
        return self._info

    def _refused(self, error: dict[str, Any]) -> None:
        self._mode = None  # a refusal may mean the mode changed under us
        super()._refused(error)

    # Streamed on the robot's session ---------------------------------------------------------

    async def stream(
        self, command: Streamed, generation: int | None = None, claim: str | None = None
    ) -> None:
        """One command on the robot's ordered session; refusals come back through on_error.
        Under `claim`, refused once that claim has ended (its caller gone)."""
        if isinstance(command, Halt):
            await self.halt(command.tag)
            return
        message = {"type": STREAM_TYPES[type(command)], **command.model_dump(exclude_none=True)}
        gen = self.generation if generation is None else generation
        await self.hub.send(self.name, gen, message, claim)

    async def halt(self, tag: str | None = None) -> None:
        """Stop always wins: on whatever link to the robot is live."""
        self._mode = None
        await self.hub.halt(self.name, tag)

    async def ensure_mode(self, mode: CommandMode, generation: int | None = None) -> None:
        """Switch the driver's mode ahead of the commands that need it, on the same ordered
        session, without waiting for a round trip; a refusal comes back through on_error."""
        gen = self.generation if generation is None else generation
        if self._mode == (mode, gen) and self.current(gen).command_mode is mode:
            return
        await self.stream(CommandModeRequest(mode=mode), gen)
        self._mode = (mode, gen)

    async def jog_joint(self, command: JogJointCommand) -> None:
        await self.stream(command)

    async def velocity_command(self, command: VelocityCommand) -> None:
        await self.stream(command)

    async def freedrive(self, command: FreedriveCommand) -> None:
        await self.stream(command)

    async def position_command(self, command: PositionCommand) -> None:
        await self.stream(command)

    # Calls -----------------------------------------------------------------------------------

    async def enable(self) -> RobotState:
        return await self._call(Robot.enable)

    async def disable(self) -> RobotState:
        return await self._call(Robot.disable)

    async def reset_errors(self) -> RobotState:
        return await self._call(Robot.reset_errors)

    async def set_command_mode(
        self, request: CommandModeRequest, generation: int | None = None, claim: str | None = None
    ) -> RobotState:
        self._mode = None
        return await self._call(Robot.set_command_mode, request, generation=generation, claim=claim)

    async def set_speed_ratio(self, request: SpeedRatioRequest) -> RobotState:
        return await self._call(Robot.set_speed_ratio, request)

    async def set_tool_setup(self, setup: ToolSetup) -> RobotDescription:
        return await self._call(Robot.set_tool_setup, setup)

    async def set_tool(self, command: ToolCommand) -> RobotState:
        return await self._call(Robot.set_tool, command)

    async def set_digital_output(self, index: int, command: DigitalOutputCommand) -> RobotState:
        return await self._call(Robot.set_digital_output, index, command)

    async def protective_stop(self, request: ProtectiveStopRequest) -> RobotState:
        return await self._call(Robot.protective_stop, request)

    async def execute_trajectory(
        self, trajectory: JointTrajectory, generation: int | None = None, claim: str | None = None
    ) -> TrajectoryAccepted:
        return await self._call(
            Robot.execute_trajectory, trajectory, generation=generation, claim=claim
        )

    async def pause_trajectory(self, generation: int | None = None) -> TrajectoryStatus:
        return await self._call(Robot.pause_trajectory, generation=generation)

    async def resume_trajectory(self, generation: int | None = None) -> TrajectoryStatus:
        return await self._call(Robot.resume_trajectory, generation=generation)

    async def trajectory_status(
        self, trajectory_id: str, generation: int | None = None
    ) -> TrajectoryStatus:
        return await self._call(Robot.trajectory_status, trajectory_id, generation=generation)

    # The run's claim -------------------------------------------------------------------------

    async def claim(self, claim: str | None = None) -> None:
        """Halt this robot if this service goes away (a program run's robots); `claim`
        names the run: commands for it are refused once it has ended or its service is gone."""
        await self.hub.claim(self.name, self.generation, claim)

    async def unclaim(self, claim: str | None = None) -> None:
        await self.hub.unclaim(self.name, claim)
