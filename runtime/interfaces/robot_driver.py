"""The abstract robot driver. Public methods check limits, mode and state, then call the
driver's protected hooks, so a driver can only ever receive a command that passed the checks."""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass

from openpendant.runtime.interfaces.device import DeviceDriver, DeviceIdentity
from openpendant.runtime.interfaces.limits import CheckedTrajectory, FloatArray, JointLimitChecker
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
    RobotFlags,
    RobotInfo,
    RobotState,
    SpeedRatioRequest,
    ToolCommand,
    ToolSetup,
    TrajectoryAccepted,
    TrajectoryStatus,
    VelocityCommand,
)
from openpendant.runtime.kit.errors import InvalidValue, RobotError
from openpendant.runtime.kit.words import words


@dataclass(frozen=True)
class RobotStatus:
    flags: RobotFlags
    command_mode: CommandMode
    error_message: str
    joint_position_command: list[float]


class RobotDriver(DeviceDriver, Robot):
    def __init__(self, identity: DeviceIdentity, info: RobotInfo) -> None:
        if identity.kind != "robot":
            raise ValueError("a robot driver needs a robot identity")
        super().__init__(identity)
        self.info = info
        self.limits = JointLimitChecker(info)
        # Counts what interrupts motion (a halt, a stop, a change of power or mode): a
        # trajectory being prepared when one comes is not started (`_refuse_if_interrupted`).
        self.interruptions = 0

    def describe(self) -> RobotDescription:
        return RobotDescription(identity=self.identity, info=self.info)

    async def shutdown(self) -> None:
        """Halt and release the robot."""
        await self.halt()

    @abstractmethod
    def state(self) -> RobotState:
        """The latest state; cheap enough to call at the streaming rate."""

    def status(self) -> RobotStatus:
        """What the command checks need. Drivers with a cheaper way than building the whole
        state (forward kinematics included) override this: it runs for every command."""
        state = self.state()
        return RobotStatus(
            state.flags, state.command_mode, state.error_message, state.joint_position_command
        )

    # Commands that are always allowed ------------------------------------------------------

    async def halt(self) -> None:
        self.interruptions += 1
        await self._halt()

    async def stop(self) -> None:
        await self.halt()

    async def protective_stop(self, request: ProtectiveStopRequest) -> RobotState:
        self.interruptions += 1
        await self._protective_stop(request.reason)
        return self.state()

    async def disable(self) -> RobotState:
        self.interruptions += 1
        await self._disable()
        return self.state()

    async def reset_errors(self) -> RobotState:
        self.interruptions += 1
        await self._reset_errors()
        return self.state()

    async def enable(self) -> RobotState:
        flags = self.status().flags
        if flags.estop:
            raise RobotError(
                "the E-stop is engaged; release it first", code="estop", words=words("robot.estop")
            )
        if flags.error:
            raise RobotError(
                "the robot has an error; reset errors first",
                code="robot_fault",
                words=words("robot.reset_first"),
            )
        self.interruptions += 1
        await self._enable()
        return self.state()

    async def set_speed_ratio(self, request: SpeedRatioRequest) -> RobotState:
        if not 0.0 < request.ratio <= 1.0:
            raise RobotError("speed ratio must be in (0, 1]", code="invalid_value")
        await self._set_speed_ratio(request.ratio)
        return self.state()

    async def set_command_mode(self, request: CommandModeRequest) -> RobotState:
        if request.mode is CommandMode.freedrive:
            self._require_freedrive()
        if request.mode is not CommandMode.halt:
            self._require_ready()
        self.interruptions += 1
        await self._set_command_mode(request.mode)
        return self.state()

    # Tool and I/O: allowed whenever the E-stop is released --------------------------------

    async def set_tool_setup(self, setup: ToolSetup) -> RobotDescription:
        """A new TCP and payload. The robot halts first: a TCP changed under a move would
        change where the move goes."""
        self._require_no_estop()
        rated = self.info.max_payload
        if rated is not None and setup.payload.mass > rated:
            raise InvalidValue(
                f"{setup.payload.mass:g} kg is over the {self.info.model}'s rated payload "
                f"of {rated:g} kg"
            )
        await self.halt()
        info = self.info.model_copy(update={"tcp": setup.tcp, "payload": setup.payload})
        await self._set_tool_setup(info)
        self.info = info
        return self.describe()

    async def set_tool(self, command: ToolCommand) -> RobotState:
        if "tool" not in self.info.capabilities:
            raise RobotError(f"{self.info.model} has no tool to open or close", code="no_tool")
        self._require_no_estop()
        await self._set_tool(command.open)
        return self.state()

    async def set_digital_output(self, index: int, command: DigitalOutputCommand) -> RobotState:
        if not 0 <= index < self.info.digital_outputs:
            raise RobotError(
                f"no digital output {index}; this robot has {self.info.digital_outputs}",
                code="unknown_io",
            )
        self._require_no_estop()
        await self._set_digital_output(index, command.value)
        return self.state()

    # Motion commands: checked, then handed to the driver -----------------------------------

    async def jog_joint(self, command: JogJointCommand) -> None:
        self._require_mode(CommandMode.jog)
        velocity = self.limits.velocities(command.velocity, "jog velocity")
        await self._jog_joint(velocity, command.timeout)

    async def freedrive(self, command: FreedriveCommand) -> None:
        self._require_freedrive()
        self._require_mode(CommandMode.freedrive)
        await self._freedrive(command.timeout)

    async def velocity_command(self, command: VelocityCommand) -> None:
        self._require_mode(CommandMode.velocity_command)
        velocity = self.limits.velocities(command.velocity, "velocity command")
        await self._velocity_command(velocity, command.timeout)

    async def position_command(self, command: PositionCommand) -> None:
        self._require_mode(CommandMode.position_command)
        position = self.limits.positions(command.position, "position command")
        velocity = (
            None
            if command.velocity is None
            else self.limits.velocities(command.velocity, "position command velocity")
        )
        await self._position_command(position, velocity, command.timeout)

    async def execute_trajectory(self, trajectory: JointTrajectory) -> TrajectoryAccepted:
        state = self._require_mode(CommandMode.trajectory)
        if state.flags.trajectory_running:
            raise RobotError("a trajectory is already running; halt it first", code="busy")
        start = self.limits.positions(state.joint_position_command, "current position")
        checked = self.limits.trajectory(trajectory, start)
        trajectory_id = await self._execute_trajectory(checked)
        return TrajectoryAccepted(id=trajectory_id, duration=checked.duration)

    async def pause_trajectory(self) -> TrajectoryStatus:
        """Bring the running trajectory to a controlled stop along its path (it stays
        `paused`, resumable). Allowed whenever one runs: slowing down is always safe."""
        return await self._pause_trajectory(True)

    async def resume_trajectory(self) -> TrajectoryStatus:
        """Continue a paused trajectory from where it stopped, along its path."""
        self._require_ready()
        return await self._pause_trajectory(False)

    # Checks ---------------------------------------------------------------------------------

    def _refuse_if_interrupted(self, prepared_since: int) -> None:
        """For a trajectory prepared while the caller waited (off the driver's lock): a STOP
        and a new trajectory mode meanwhile must not let the stopped move start after all."""
        if self.interruptions != prepared_since:
            raise RobotError(
                "the robot was halted, or its power or mode changed, while the trajectory was "
                "prepared: it was not started",
                code="interrupted",
            )

    def _require_no_estop(self) -> None:
        if self.status().flags.estop:
            raise RobotError(
                "the E-stop is engaged; release it first", code="estop", words=words("robot.estop")
            )

    def _require_freedrive(self) -> None:
        if "freedrive" not in self.info.capabilities:
            raise RobotError(
                f"the {self.info.model} cannot be moved by hand (no freedrive)", code="no_freedrive"
            )

    def _require_ready(self) -> RobotStatus:
        state = self.status()
        flags = state.flags
        if flags.estop:
            raise RobotError("the E-stop is engaged", code="estop", words=words("robot.estop"))
        if flags.error:
            raise RobotError(
                f"the robot has an error: {state.error_message}",
                code="robot_fault",
                words=words("robot.fault", error=state.error_message),
            )
        if not flags.enabled:
            raise RobotError(
                "the robot is not enabled", code="not_enabled", words=words("robot.not_enabled")
            )
        return state

    def _require_mode(self, mode: CommandMode) -> RobotStatus:
        state = self._require_ready()
        if state.command_mode is not mode:
            raise RobotError(
                f"command needs mode {mode.value}; the robot is in {state.command_mode.value}",
                code="wrong_mode",
                words=words("robot.wrong_mode", needed=mode.value, mode=state.command_mode.value),
            )
        return state

    # Driver hooks ---------------------------------------------------------------------------

    @abstractmethod
    async def _enable(self) -> None: ...

    @abstractmethod
    async def _disable(self) -> None: ...

    @abstractmethod
    async def _reset_errors(self) -> None: ...

    @abstractmethod
    async def _halt(self) -> None: ...

    async def _protective_stop(self, reason: str) -> None:
        """Stop and hold until errors are reset. A driver whose robot cannot latch a stop
        of the runtime's only halts it."""
        await self._halt()

    @abstractmethod
    async def _set_command_mode(self, mode: CommandMode) -> None:
        """Change mode; a change between two motion modes passes through halt."""

    @abstractmethod
    async def _set_speed_ratio(self, ratio: float) -> None: ...

    @abstractmethod
    async def _jog_joint(self, velocity: FloatArray, timeout: float) -> None: ...

    @abstractmethod
    async def _velocity_command(self, velocity: FloatArray, timeout: float) -> None: ...

    async def _freedrive(self, timeout: float) -> None:
        """Free to be moved by hand for `timeout` more seconds (drivers that declare the
        `freedrive` capability implement it)."""
        raise RobotError("this driver has no freedrive", code="no_freedrive")

    @abstractmethod
    async def _position_command(
        self, position: FloatArray, velocity: FloatArray | None, timeout: float
    ) -> None: ...

    @abstractmethod
    async def _execute_trajectory(self, trajectory: CheckedTrajectory) -> str: ...

    async def _pause_trajectory(self, paused: bool) -> TrajectoryStatus:
        raise RobotError(f"{self.info.model}: this driver cannot pause a trajectory", code="busy")

    async def _set_tool_setup(self, info: RobotInfo) -> None:
        """Apply `info`'s TCP and payload (the controller's own TCP and payload settings)."""
        raise RobotError(f"{self.info.model}: this driver cannot set a TCP", code="no_tool")

    async def _set_tool(self, open_: bool) -> None:
        raise RobotError(f"{self.info.model}: this driver cannot drive a tool", code="no_tool")

    async def _set_digital_output(self, index: int, value: bool) -> None:
        raise RobotError(f"{self.info.model}: this driver has no digital I/O", code="unknown_io")
