"""An emulated UR controller until interrupted:
`python -m openpendant.device_drivers.ur_rtde.emulator --host 127.0.0.2 [--model ur5e]`.
It runs in a process of its own: ur-rtde's calls block in C++ holding Python's interpreter
lock, so a client and the emulator cannot share one."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import logging
import signal
import sys

from openpendant.device_drivers.sim_cell.link import CellServer
from openpendant.device_drivers.sim_cell.world import World
from openpendant.device_drivers.ur_rtde.emulator.controller import Controller
from openpendant.device_drivers.ur_rtde.emulator.servers import Emulator
from openpendant.device_drivers.ur_rtde.models import CB3
from openpendant.runtime.robotics.robot_info import available_models, load_robot_info


async def serve(host: str, model: str, cell: str) -> None:
    controller = Controller(load_robot_info(model))
    emulator = Emulator(controller, host)
    await emulator.start()
    world = None
    if cell:  # parts on its table, for simulated grippers and sensors named after it
        world = CellServer(World(controller.tcp), cell)
        await world.start()
    # A full collection stops every thread: over what start-up loaded it would let input
    # packages queue while the watchdog check runs (as the driver's host, runtime/kit/app.py).
    gc.collect()
    gc.freeze()
    print(f"UR emulator ready on {host}", flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()
    if world is not None:
        await world.stop()
    await emulator.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m openpendant.device_drivers.ur_rtde.emulator")
    parser.add_argument("--host", default="127.0.0.2", help="the address to serve on")
    e_series = [m for m in available_models() if m.startswith("ur") and m not in CB3]
    parser.add_argument("--model", default="ur5e", help=", ".join(e_series))
    parser.add_argument(
        "--cell", default="", help="serve a simulated cell under this name (see sim_cell)"
    )
    args = parser.parse_args(argv)
    if args.model in CB3:  # it reports PolyScope 5 and streams at 500 Hz, as an e-Series does
        parser.error(f"the emulator is an e-Series controller: give one of {', '.join(e_series)}")
    # Its control loop and the state streams are threads that must get the interpreter back
    # within their 2 ms cycles (the default switch interval is 5 ms).
    sys.setswitchinterval(0.0005)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(serve(args.host, args.model, args.cell))
    return 0


if __name__ == "__main__":
    sys.exit(main())
