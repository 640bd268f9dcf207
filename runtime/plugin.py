"""The runtime's own contributions, registered like any plugin's: the device kinds of the
standard interfaces, the services, and the built-in variable types."""

from __future__ import annotations

from openpendant.plugins.api import DeviceKind, Plugin, Service, VariableType

IF = "openpendant.runtime.interfaces"
C = "openpendant.runtime.clients"
T = "openpendant.runtime.variable_storage.types"

PLUGIN = Plugin(
    name="core",
    description="The standard device kinds, the runtime's services and variable types",
    kinds=(
        DeviceKind(
            "robot",
            f"{IF}.robot:Robot",
            f"{IF}.robot:RobotState",
            f"{C}.robot:RobotClient",
            "an industrial robot arm",
            session=True,
            tool=True,
            routes="openpendant.runtime.drivers.robot_routes:command_router",
        ),
        DeviceKind(
            "input",
            f"{IF}.input:InputDevice",
            f"{IF}.input:InputState",
            f"{C}.input:InputClient",
            "a 3D mouse or another input device",
        ),
        DeviceKind(
            "camera",
            f"{IF}.camera:Camera",
            f"{IF}.camera:CameraState",
            f"{C}.kinds:CameraClient",
            "a camera",
            frames=True,
            routes="openpendant.runtime.drivers.camera_routes:frames_router",
        ),
        DeviceKind(
            "detector",
            f"{IF}.detector:Detector",
            f"{IF}.detector:DetectorState",
            f"{C}.kinds:DetectorClient",
            "an object detector",
        ),
        DeviceKind(
            "io",
            f"{IF}.io:IOBlock",
            f"{IF}.io:IOState",
            f"{C}.kinds:IOClient",
            "a block of digital and analog inputs and outputs",
        ),
        DeviceKind(
            "gripper",
            f"{IF}.gripper:Gripper",
            f"{IF}.gripper:GripperState",
            f"{C}.kinds:GripperClient",
            "a gripper",
        ),
    ),
    services=(
        Service(
            "variable_storage",
            "openpendant.runtime.variable_storage.service:build_app",
            ("variables",),
        ),
        Service(
            "device_manager", "openpendant.runtime.device_manager.service:build_app", ("devices",)
        ),
        Service(
            "jog", "openpendant.runtime.jog.service:build_app", ("jog",), public_paths=("/jog/ws",)
        ),
        Service("motion", "openpendant.runtime.motion.service:build_app", ("motion",)),
        Service("program", "openpendant.runtime.program.service:build_app", ("programs",)),
        Service("vision", "openpendant.runtime.vision.service:build_app", ("vision",)),
    ),
    variable_types=(
        VariableType("number", "a finite number", f"{T}:number"),
        VariableType("string", "text", f"{T}:string"),
        VariableType("bool", "true or false", f"{T}:boolean"),
        VariableType(
            "joint_waypoint",
            "joint positions (rad) and the robot they were taught on",
            f"{IF}.variables:JointWaypoint",
        ),
        VariableType(
            "pose_waypoint",
            "a TCP pose (m, unit quaternion) in a frame",
            f"{IF}.variables:PoseWaypoint",
        ),
        VariableType(
            "pose", "a pose: position (m) and orientation (unit quaternion)", f"{IF}.common:Pose"
        ),
        VariableType(
            "frame", "a coordinate frame: pose in a parent frame", f"{IF}.variables:Frame"
        ),
        VariableType("list", "a list of JSON values", f"{T}:json_list"),
        VariableType("json", "any JSON value", f"{T}:any_json"),
        VariableType("device", "a device added under a local name", f"{IF}.variables:DeviceRecord"),
        VariableType(
            "tool",
            "what a robot carries: its TCP (in the flange frame) and payload",
            f"{IF}.robot:ToolSetup",
        ),
        VariableType(
            "scene_object",
            "an obstacle, keep-out zone or held object of the scene",
            f"{IF}.scene:SceneObject",
        ),
        VariableType(
            "camera_calibration",
            "a camera's intrinsics as calibrated, with their errors",
            "openpendant.runtime.vision.models:CameraCalibration",
        ),
        VariableType(
            "calibration_board",
            "a calibration board as printed: ChArUco or chessboard, squares and sizes",
            "openpendant.runtime.imaging.boards:BoardSpec",
        ),
        VariableType(
            "detector",
            "how a detector finds things, through which camera",
            "openpendant.runtime.vision.detectors:DetectorConfig",
        ),
        VariableType(
            "program",
            "a program: its Blockly workspace and generated Python",
            f"{IF}.variables:StoredProgram",
        ),
    ),
)
