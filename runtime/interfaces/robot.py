"""The standard robot interface, after Robot Raconteur's com.robotraconteur.robotics.robot."""

from __future__ import annotations

from abc import ABC, abstractmethod
from enum import StrEnum
from typing import Annotated

from pydantic import BaseModel, Field, model_validator

from openpendant.runtime.interfaces.common import JointVector, Pose, Strict, Vector3
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.endpoints import endpoint

MAX_COMMAND_TIMEOUT = 1.0


class CommandMode(StrEnum):
    halt = "halt"
    jog = "jog"
    trajectory = "trajectory"
    position_command = "position_command"
    velocity_command = "velocity_command"
    # Held free to be moved by hand (a UR's teach mode) while freedrive commands keep coming.
    freedrive = "freedrive"


class OperationalMode(StrEnum):
    manual_reduced_speed = "manual_reduced_speed"
    manual_full_speed = "manual_full_speed"
    auto = "auto"
    undefined = "undefined"


class JointLimits(Strict):
    name: str = Field(min_length=1, max_length=64)
    lower: float
    upper: float
    max_velocity: float = Field(gt=0)
    max_acceleration: float = Field(gt=0)
    max_jerk: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> JointLimits:
        if not self.lower < self.upper:
            raise ValueError(f"joint {self.name}: lower limit must be below upper limit")
        return self


MAX_TOOL_REACH = 2.0  # m from the flange: a TCP or centre of mass further out is a typo


class Payload(Strict):
    """What the robot carries beyond its flange: the tool and what it holds."""

    mass: float = Field(default=0.0, ge=0.0, le=1000.0)  # kg
    center_of_mass: Vector3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])  # m, flange frame


class ToolSetup(Strict):
    """What is mounted on the flange: the tool centre point (its pose in the flange frame),
    which jogging, moves and waypoints refer to, and the payload."""

    tcp: Pose = Field(default_factory=Pose)
    payload: Payload = Field(default_factory=Payload)

    @model_validator(mode="after")
    def _near_the_flange(self) -> ToolSetup:
        points = (("TCP", self.tcp.position), ("centre of mass", self.payload.center_of_mass))
        for what, point in points:
            if sum(c * c for c in point) ** 0.5 > MAX_TOOL_REACH:
                raise ValueError(f"the {what} is over {MAX_TOOL_REACH:g} m from the flange")
        return self


SIM_CELL = "sim_cell"
# What a driver's power commands do beyond the standard's (the UI names its buttons so):
# Enable also powers the arm on and releases its brakes; Reset errors also unlocks a
# protective stop.
POWER_ON = "power_on"
UNLOCK_PROTECTIVE_STOP = "unlock_protective_stop"


class RobotInfo(Strict):
    """Loaded from a robot-info YAML; the URDF gives kinematics and collision geometry."""

    model: str = Field(min_length=1, max_length=64)
    manufacturer: str = ""
    description: str = ""
    urdf: str = Field(min_length=1)
    base_link: str
    flange_link: str
    tcp: Pose = Field(default_factory=Pose)
    payload: Payload = Field(default_factory=Payload)
    max_payload: float | None = Field(default=None, gt=0)  # kg, the rated payload
    joints: list[JointLimits] = Field(min_length=1, max_length=64)
    home: JointVector
    # "sim_cell": a simulator with parts on its table, listed at GET /sim/cell/parts.
    capabilities: list[str] = Field(default_factory=list)
    # The controller's digital I/O, numbered from 0 ("tool" in capabilities: a gripper).
    digital_inputs: int = Field(default=0, ge=0, le=64)
    digital_outputs: int = Field(default=0, ge=0, le=64)

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def dof(self) -> int:
        return len(self.joints)

    @model_validator(mode="after")
    def _home_within_limits(self) -> RobotInfo:
        if len(self.home) != len(self.joints):
            raise ValueError(f"home has {len(self.home)} values for {len(self.joints)} joints")
        for value, joint in zip(self.home, self.joints, strict=True):
            if not joint.lower <= value <= joint.upper:
                raise ValueError(f"home of joint {joint.name} is outside its limits")
        return self


class RobotFlags(BaseModel):
    enabled: bool = False
    ready: bool = False
    error: bool = False
    estop: bool = False
    # A safety stop the robot made on its own (a collision, a guard opened, a limit): it
    # holds until the cause is gone and errors are reset.
    protective_stop: bool = False
    # The controller's safety limits are the reduced set (a UR's "reduced mode").
    reduced_speed: bool = False
    homed: bool = False
    communication_failure: bool = False
    trajectory_running: bool = False


class TrajectoryState(StrEnum):
    running = "running"
    paused = "paused"  # brought to a stop on its path; resumes where it stopped
    finished = "finished"
    aborted = "aborted"
    failed = "failed"


class TrajectoryStatus(BaseModel):
    id: str
    state: TrajectoryState
    progress: float = 0.0
    message: str = ""


class RobotState(BaseModel):
    seqno: int
    ts: float
    command_mode: CommandMode
    operational_mode: OperationalMode
    flags: RobotFlags
    joint_position: list[float]
    joint_velocity: list[float]
    joint_position_command: list[float]
    tcp_pose: Pose
    speed_ratio: float
    error_message: str = ""
    trajectory: TrajectoryStatus | None = None
    tool_open: bool | None = None  # None: no tool, or not known yet
    digital_inputs: list[bool] = Field(default_factory=list)
    digital_outputs: list[bool] = Field(default_factory=list)


class RobotDescription(BaseModel):
    identity: DeviceIdentity
    info: RobotInfo


# Commands ---------------------------------------------------------------------------------

CommandTimeout = Annotated[float, Field(gt=0, le=MAX_COMMAND_TIMEOUT)]
# A client's label for a command, kept in the driver's command log (tracing, timing).
Tag = Annotated[str | None, Field(default=None, max_length=64)]


class CommandModeRequest(Strict):
    mode: CommandMode


class FreedriveCommand(Strict):
    """Keep the arm free to be moved by hand until `timeout` s pass without a new command
    (hold to run). Only for a robot with the `freedrive` capability, in freedrive mode."""

    timeout: CommandTimeout = 0.2
    tag: Tag = None


class JogJointCommand(Strict):
    """Move at these joint velocities (rad/s) until `timeout` s pass without a new command."""

    velocity: JointVector
    timeout: CommandTimeout = 0.2
    tag: Tag = None


class VelocityCommand(Strict):
    velocity: JointVector
    timeout: CommandTimeout = 0.1
    tag: Tag = None


class PositionCommand(Strict):
    """One sample of a streamed joint position setpoint."""

    position: JointVector
    velocity: JointVector | None = None
    timeout: CommandTimeout = 0.1
    tag: Tag = None


class TrajectoryWaypoint(Strict):
    time_from_start: float = Field(ge=0)
    position: JointVector
    velocity: JointVector | None = None
    # With velocities: makes the interpolation follow the planned acceleration exactly
    # (estimated from the neighbouring velocities otherwise).
    acceleration: JointVector | None = None


class JointTrajectory(Strict):
    """Starts from the current position at t=0; waypoints follow in increasing time."""

    waypoints: list[TrajectoryWaypoint] = Field(min_length=1, max_length=200_000)


class ProtectiveStopRequest(Strict):
    # Why, as the robot's error message shows it until errors are reset.
    reason: str = Field(min_length=1, max_length=200)


class ToolCommand(Strict):
    open: bool


class DigitalOutputCommand(Strict):
    value: bool


class SpeedRatioRequest(Strict):
    ratio: float = Field(gt=0, le=1)


class TrajectoryAccepted(BaseModel):
    id: str
    duration: float


# The interface ---------------------------------------------------------------------------


class Robot(ABC):
    """The standard robot, on both sides of the wire: the driver implements it with its
    checks (`RobotDriver`), the typed client over the robot's one link (`RobotClient`).
    Commands with a `stream` type also go, in order, over the runtime's command session."""

    @endpoint("POST", "/enable", returns=RobotState)
    @abstractmethod
    async def enable(self) -> RobotState: ...

    @endpoint("POST", "/disable", returns=RobotState)
    @abstractmethod
    async def disable(self) -> RobotState: ...

    @endpoint("POST", "/reset_errors", returns=RobotState)
    @abstractmethod
    async def reset_errors(self) -> RobotState: ...

    @endpoint("POST", "/halt", stream="halt")
    @abstractmethod
    async def halt(self) -> None:
        """Stop now, whatever runs; always allowed."""

    @endpoint(
        "POST",
        "/protective_stop",
        body=ProtectiveStopRequest,
        returns=RobotState,
        label=lambda _: "protective_stop",
    )
    @abstractmethod
    async def protective_stop(self, request: ProtectiveStopRequest) -> RobotState:
        """Stop now and hold, as the robot's own safety stop would, until errors are reset
        (the runtime's path monitor: the TCP left its checked path); always allowed."""

    @endpoint(
        "PUT",
        "/command_mode",
        body=CommandModeRequest,
        returns=RobotState,
        stream="command_mode",
        label=lambda body: f"command_mode:{body.mode.value}",
    )
    @abstractmethod
    async def set_command_mode(self, request: CommandModeRequest) -> RobotState:
        """A change between two motion modes passes through halt."""

    @endpoint("PUT", "/speed_ratio", body=SpeedRatioRequest, returns=RobotState)
    @abstractmethod
    async def set_speed_ratio(self, request: SpeedRatioRequest) -> RobotState: ...

    @endpoint("PUT", "/tool_setup", body=ToolSetup, returns=RobotDescription)
    @abstractmethod
    async def set_tool_setup(self, setup: ToolSetup) -> RobotDescription:
        """The mounted tool's TCP and payload; the robot halts first. Answers the new info."""

    @endpoint(
        "POST",
        "/tool",
        body=ToolCommand,
        returns=RobotState,
        label=lambda body: "tool:open" if body.open else "tool:close",
    )
    @abstractmethod
    async def set_tool(self, command: ToolCommand) -> RobotState: ...

    @endpoint(
        "PUT",
        "/digital_outputs/{index}",
        body=DigitalOutputCommand,
        returns=RobotState,
        label=lambda index, body: f"digital_output:{index}:{int(body.value)}",
    )
    @abstractmethod
    async def set_digital_output(self, index: int, command: DigitalOutputCommand) -> RobotState: ...

    @endpoint("POST", "/jog_joint", body=JogJointCommand, stream="jog_joint")
    @abstractmethod
    async def jog_joint(self, command: JogJointCommand) -> None:
        """Holds until `timeout` (at most 1 s) passes without a new command."""

    @endpoint("POST", "/freedrive", body=FreedriveCommand, stream="freedrive")
    @abstractmethod
    async def freedrive(self, command: FreedriveCommand) -> None:
        """The arm stays free to be moved by hand until `timeout` passes without a new
        command; then it holds where it is."""

    @endpoint("POST", "/velocity_command", body=VelocityCommand, stream="velocity_command")
    @abstractmethod
    async def velocity_command(self, command: VelocityCommand) -> None: ...

    @endpoint("POST", "/position_command", body=PositionCommand, stream="position_command")
    @abstractmethod
    async def position_command(self, command: PositionCommand) -> None: ...

    @endpoint(
        "POST",
        "/trajectory",
        body=JointTrajectory,
        returns=TrajectoryAccepted,
        label=lambda _: "trajectory",
    )
    @abstractmethod
    async def execute_trajectory(self, trajectory: JointTrajectory) -> TrajectoryAccepted:
        """Starts at the current position at t = 0."""

    @endpoint(
        "POST", "/trajectory/pause", returns=TrajectoryStatus, label=lambda: "trajectory:pause"
    )
    @abstractmethod
    async def pause_trajectory(self) -> TrajectoryStatus:
        """A controlled stop along the running trajectory's path; resumable."""

    @endpoint(
        "POST", "/trajectory/resume", returns=TrajectoryStatus, label=lambda: "trajectory:resume"
    )
    @abstractmethod
    async def resume_trajectory(self) -> TrajectoryStatus: ...

    @endpoint("GET", "/trajectory/{trajectory_id}", returns=TrajectoryStatus)
    @abstractmethod
    async def trajectory_status(self, trajectory_id: str) -> TrajectoryStatus: ...
