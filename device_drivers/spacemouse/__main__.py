"""Serve a 3Dconnexion SpaceMouse as an input device, advertised on the network:

openpendant spacemouse [--source hid|spacenavd|replay] [--name NAME] [--port 0]
"""

from __future__ import annotations

import argparse
import os
import sys
import uuid
from pathlib import Path

from fastapi import APIRouter, Response

from device_drivers.spacemouse.driver import SpaceMouseDriver
from device_drivers.spacemouse.reports import AxisSettings
from device_drivers.spacemouse.sources import (
    HidSource,
    ReplaySource,
    ReportSource,
    SpacenavdSource,
)
from runtime.drivers.host import serve_driver
from runtime.interfaces.device import DeviceIdentity
from runtime.interfaces.input import AXES, InputInfo
from runtime.kit.logs import setup_logging
from runtime.kit.settings import SETTINGS_ENV, load_settings, settings_from_env

UUID_NAMESPACE = uuid.UUID("0b4c4d2e-7d8e-4a55-8f4e-2a3c9b1d6e77")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="openpendant spacemouse",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--source", choices=["hid", "spacenavd", "replay"], default="hid")
    p.add_argument("--replay", type=Path, help="recording to play (with --source replay)")
    p.add_argument(
        "--replay-wait", action="store_true", help="play the recording only on POST /replay/start"
    )
    p.add_argument("--socket", default="/var/run/spnav.sock", help="spacenavd's socket")
    p.add_argument("--vendor", type=lambda v: int(v, 0), default=None, help="USB vendor id")
    p.add_argument("--product", type=lambda v: int(v, 0), default=None, help="USB product id")
    p.add_argument("--name", default="spacemouse", help="advertised name")
    p.add_argument("--uuid", default=None)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--config", type=Path, default=None, help="runtime YAML config")
    p.add_argument("--dead-zone", type=float, default=0.05, help="fraction of full deflection")
    p.add_argument("--sensitivity", default="1,1,1,1,1,1", help="six gains, x y z rx ry rz")
    p.add_argument(
        "--source-axis", default="0,1,2,3,4,5", help="which raw axis drives x y z rx ry rz"
    )
    p.add_argument("--invert", default="y,z,ry,rz", help="axes to invert (empty for none)")
    return p


def replay_router(source: ReplaySource) -> APIRouter:
    router = APIRouter(prefix="/replay")

    @router.post("/start", status_code=204)
    async def start() -> Response:
        source.restart()
        return Response(status_code=204)

    return router


def make_source(args: argparse.Namespace) -> ReportSource:
    if args.source == "replay":
        if args.replay is None or not args.replay.is_file():
            raise SystemExit("openpendant spacemouse: --source replay needs --replay FILE")
        return ReplaySource(args.replay, wait_for_start=args.replay_wait)
    if args.source == "spacenavd":
        return SpacenavdSource(args.socket)
    return HidSource(args.vendor, args.product)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if os.environ.get(SETTINGS_ENV) and args.config is None:
        settings = settings_from_env()
    else:
        settings = load_settings(args.config, host=args.host)
    setup_logging("spacemouse", settings.log_level)
    try:
        axis_settings = AxisSettings(
            dead_zone=args.dead_zone,
            sensitivity=[float(v) for v in args.sensitivity.split(",")],
            source_axis=[int(v) for v in args.source_axis.split(",")],
            invert=[a for a in args.invert.split(",") if a],
        )
    except ValueError as exc:
        print(f"openpendant spacemouse: {exc}", file=sys.stderr)
        return 2
    source = make_source(args)
    device_uuid = args.uuid or str(uuid.uuid5(UUID_NAMESPACE, f"spacemouse/{args.name}"))
    identity = DeviceIdentity(uuid=device_uuid, kind="input", model="spacemouse", name=args.name)
    info = InputInfo(model="SpaceMouse", axes=list(AXES), source=args.source)
    driver = SpaceMouseDriver(identity, info, source, axis_settings, reopen=args.source != "replay")
    routers = [replay_router(source)] if isinstance(source, ReplaySource) else []
    serve_driver(
        driver,
        host=args.host,
        port=args.port,
        routers=routers,
        interfaces=settings.zeroconf_interfaces(),
        state_rate_hz=settings.state_rate_hz,
        ttl=settings.discovery.ttl,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
