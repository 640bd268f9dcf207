"""Run one simulated robot as its own process, advertised on the network:

openpendant sim-robot --model ur5 --name cell-2-ur5 [--port 0]
"""

from __future__ import annotations

import argparse
import os
import sys
import uuid
from pathlib import Path

from device_drivers.sim_robot.driver import SimRobot
from device_drivers.sim_robot.routes import sim_router
from runtime.drivers.command_log import CommandLog
from runtime.drivers.host import serve_driver
from runtime.drivers.robot_routes import robot_router
from runtime.interfaces.device import DeviceIdentity
from runtime.kit.errors import OpenPendantError
from runtime.kit.logs import setup_logging
from runtime.kit.settings import SETTINGS_ENV, load_settings, settings_from_env
from runtime.robot_info import available_models, load_robot_info

UUID_NAMESPACE = uuid.UUID("6f1d9a52-3c39-4b61-9d0e-5c2a1f6b7e10")


def sim_uuid(model: str, name: str) -> str:
    """Stable across restarts, like a serial number, so the device is recognised again."""
    return str(uuid.uuid5(UUID_NAMESPACE, f"sim-robot/{model}/{name}"))


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="openpendant sim-robot",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--model",
        default="ur5",
        help=f"robot model ({', '.join(available_models())}) or a robot-info YAML",
    )
    p.add_argument("--name", default=None, help="advertised name (default sim-<model>)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=0, help="0 picks a free port")
    p.add_argument("--uuid", default=None, help="device uuid (default: derived from the name)")
    p.add_argument("--config", type=Path, default=None, help="runtime YAML config")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if os.environ.get(SETTINGS_ENV) and args.config is None:
        settings = settings_from_env()  # started by the launcher: its settings exactly
    else:
        settings = load_settings(args.config, host=args.host)
    setup_logging("sim-robot", settings.log_level)
    # The control loop thread must get the GIL back within a fraction of its 2 ms cycle.
    sys.setswitchinterval(0.0005)
    try:
        info = load_robot_info(args.model)
    except OpenPendantError as exc:
        print(f"openpendant sim-robot: {exc.message}", file=sys.stderr)
        return 2
    name = args.name or f"sim-{info.model}"
    identity = DeviceIdentity(
        uuid=args.uuid or sim_uuid(info.model, name), kind="robot", model=info.model, name=name
    )
    robot = SimRobot(identity, info)
    serve_driver(
        robot,
        host=args.host,
        port=args.port,
        interfaces=settings.zeroconf_interfaces(),
        state_rate_hz=settings.state_rate_hz,
        ttl=settings.discovery.ttl,
        routers=[robot_router(robot, CommandLog()), sim_router(robot)],
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
