"""Robot Raconteur, the middleware of PyRI and its drivers, as an OpenPendant plugin (the
`rr` extra: `pip install openpendant[rr]`). Nothing here imports RR until one of its drivers
runs."""

from openpendant.plugins.api import Driver, Plugin

PLUGIN = Plugin(
    name="robotraconteur",
    description="Robot Raconteur standard robots, cameras and tools",
    drivers=(
        Driver(
            "rr-robot",
            "robot",
            "openpendant.plugins.robotraconteur.entry:create",
            options="openpendant.plugins.robotraconteur.entry:RRRobotOptions",
            description="a Robot Raconteur standard robot, by its URL (rr+tcp://…)",
            realtime=True,
        ),
        Driver(
            "rr-camera",
            "camera",
            "openpendant.plugins.robotraconteur.entry:create_camera",
            options="openpendant.plugins.robotraconteur.entry:RRCameraOptions",
            description="a Robot Raconteur standard camera, by its URL (rr+tcp://…)",
        ),
        Driver(
            "rr-tool",
            "gripper",
            "openpendant.plugins.robotraconteur.entry:create_tool",
            options="openpendant.plugins.robotraconteur.entry:RRToolOptions",
            description="a Robot Raconteur standard tool (a gripper), by its URL (rr+tcp://…)",
        ),
    ),
)
