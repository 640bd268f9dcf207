"""The UR driver against the controller emulator (ur-rtde underneath, the emulator in its
own process on 127.0.0.9): how many controller states a second reach the driver, and how
long a jog press takes from the driver's interface to the speedJ the emulated controller
runs (monotonic clocks: one clock for every process of the computer)."""

from __future__ import annotations

import asyncio
import gc
import time
from typing import Any

import numpy as np

from device_drivers.ur_rtde.driver import URDriver
from device_drivers.ur_rtde.emulator.control import emulated, start, stop
from runtime.bench.runner import Figure
from runtime.bench.stats import quick
from runtime.interfaces.device import DeviceIdentity
from runtime.interfaces.robot import CommandMode, CommandModeRequest, JogJointCommand
from runtime.robotics.robot_info import load_robot_info

FIGURES = ("ur_state_rate", "ur_jog_command_latency_p50", "ur_jog_command_latency_p99")
HOST = "127.0.0.9"
SPEEDJ = "9"


def _emulated() -> dict[str, Any]:
    return emulated(HOST)


async def _wait(check: object, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():  # type: ignore[operator]
        if time.monotonic() > deadline:
            raise TimeoutError("the UR emulator did not get there")
        await asyncio.sleep(0.005)


def _sampled_rate(receive: object, seconds: float) -> float:
    """Distinct controller time stamps a second, sampled every 0.2 ms (faster than they come,
    so none is missed unless the stream itself skips it)."""
    stamps = set()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        stamps.add(receive.getTimestamp())  # type: ignore[attr-defined]
        time.sleep(0.0002)
    return len(stamps) / seconds


async def _measure(presses: int, seconds: float) -> tuple[float, list[float]]:
    info = load_robot_info("ur5e")
    # As in the driver's host: no full collection over what is loaded stalls the control
    # thread past the RTDE watchdog (unfrozen after, so that it all ends with the process).
    gc.collect()
    gc.freeze()
    driver = URDriver(
        DeviceIdentity(uuid="bench-ur", kind="robot", model=info.model, name="ur"), info, HOST
    )
    await driver.start()
    try:
        await _wait(lambda: not driver.state().flags.communication_failure)
        await driver.enable()
        link = driver.link
        assert link is not None
        # States: distinct controller time stamps seen by the driver's receive interface.
        rate = await asyncio.to_thread(_sampled_rate, link.receive, seconds)
        await driver.set_command_mode(CommandModeRequest(mode=CommandMode.jog))
        latencies = []
        for k in range(presses):
            sign = 1 if k % 2 == 0 else -1
            before = _emulated()["started_at"].get(SPEEDJ, 0.0)
            t0 = time.monotonic()
            await driver.jog_joint(
                JogJointCommand(velocity=[0.05 * sign, 0, 0, 0, 0, 0], timeout=0.05)
            )
            started = before
            while started == before:
                await asyncio.sleep(0.001)
                started = _emulated()["started_at"].get(SPEEDJ, 0.0)
            latencies.append((float(started) - t0) * 1000)
            await _wait(lambda: max(abs(v) for v in _emulated()["qd"]) < 1e-6)
        return rate, latencies
    finally:
        await driver.shutdown()
        gc.unfreeze()


def run() -> list[Figure]:
    emulator = start(HOST)
    try:
        presses = 20 if quick() else 200
        rate, latencies = asyncio.run(_measure(presses, 1.0 if quick() else 3.0))
    finally:
        stop(emulator)
    details = {"path": "URDriver → ur-rtde → RTDE on loopback → emulator (500 Hz e-Series)"}
    jog = {**details, "presses": presses, "note": "press to the first cycle running speedJ"}
    return [
        Figure(
            "ur_state_rate", rate, "Hz", target="500", meets_target=rate >= 495, details=details
        ),
        Figure(
            "ur_jog_command_latency_p50", float(np.percentile(latencies, 50)), "ms", details=jog
        ),
        Figure(
            "ur_jog_command_latency_p99",
            float(np.percentile(latencies, 99)),
            "ms",
            target="≤ 10",
            meets_target=float(np.percentile(latencies, 99)) <= 10,
            details=jog,
        ),
    ]
