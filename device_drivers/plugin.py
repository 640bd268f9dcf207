"""The drivers that come with OpenPendant, registered through the plugin API like a
plugin's: `openpendant driver NAME`, and the runtime config's `devices:` list."""

from __future__ import annotations

from openpendant.plugins.api import Driver, Plugin

PLUGIN = Plugin(
    name="drivers",
    description="The simulated robot and camera, the 3D mouse, UR arms, Modbus I/O and grippers",
    drivers=(
        Driver(
            "sim-robot",
            "robot",
            "openpendant.device_drivers.sim_robot.entry:create",
            options="openpendant.device_drivers.sim_robot.entry:SimRobotOptions",
            routes="openpendant.device_drivers.sim_robot.entry:routes",
            description="a simulated robot (UR3, UR5, UR10, Panda or a robot-info YAML)",
            realtime=True,
            simulated=True,
        ),
        Driver(
            "sim-camera",
            "camera",
            "openpendant.device_drivers.sim_camera.entry:create",
            options="openpendant.device_drivers.sim_camera.entry:SimCameraOptions",
            routes="openpendant.device_drivers.sim_camera.entry:routes",
            description="a simulated camera above the cell, with a ChArUco board to show it",
            simulated=True,
        ),
        Driver(
            "opencv-camera",
            "camera",
            "openpendant.device_drivers.opencv_camera.entry:create",
            options="openpendant.device_drivers.opencv_camera.entry:OpenCVCameraOptions",
            description="a camera OpenCV opens: USB, a stream, a video file or an image folder",
        ),
        Driver(
            "ur-rtde",
            "robot",
            "openpendant.device_drivers.ur_rtde.entry:create",
            options="openpendant.device_drivers.ur_rtde.entry:UROptions",
            description="a Universal Robots arm over RTDE (ur-rtde)",
            realtime=True,
        ),
        Driver(
            "ur-io",
            "io",
            "openpendant.device_drivers.ur_rtde.io_entry:create",
            options="openpendant.device_drivers.ur_rtde.io_entry:URIOOptions",
            description="a Universal Robots controller's digital, analog and tool I/O (ur-rtde)",
        ),
        Driver(
            "spacemouse",
            "input",
            "openpendant.device_drivers.spacemouse.entry:create",
            options="openpendant.device_drivers.spacemouse.entry:SpaceMouseOptions",
            routes="openpendant.device_drivers.spacemouse.entry:routes",
            description="a 3Dconnexion SpaceMouse (hidapi, spacenavd, or a recording)",
        ),
        Driver(
            "modbus-io",
            "io",
            "openpendant.device_drivers.modbus_io.entry:create",
            options="openpendant.device_drivers.modbus_io.entry:ModbusIOOptions",
            routes="openpendant.device_drivers.modbus_io.entry:routes",
            description="an I/O block over Modbus TCP or RTU (a register map; --simulate: a sim)",
        ),
        Driver(
            "modbus-gripper",
            "gripper",
            "openpendant.device_drivers.modbus_io.gripper_entry:create",
            options="openpendant.device_drivers.modbus_io.gripper_entry:ModbusGripperOptions",
            routes="openpendant.device_drivers.modbus_io.gripper_entry:routes",
            description="a Robotiq 2F-85/2F-140 or a gripper on digital I/O, over Modbus",
        ),
    ),
)
