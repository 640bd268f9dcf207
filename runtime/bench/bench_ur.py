"""The UR driver against the controller emulator (ur-rtde underneath, the emulator in its
own process on 127.0.0.9): how many controller states a second reach the driver, how long
a jog press takes from the driver's interface to the speedJ the emulated controller runs
(monotonic clocks: one clock for every process of the computer), and how far the emulated
arm leaves the straight line of bench_path_fidelity's fast linear moves (automatic mode,
speed 1, acceleration 1) streamed to it by the driver with servoJ."""

from __future__ import annotations

import asyncio
import contextlib
import gc
import time
from collections.abc import AsyncIterator
from typing import Any

import numpy as np

from openpendant.device_drivers.ur_rtde.driver import URDriver
from openpendant.device_drivers.ur_rtde.emulator.control import (
    emulated,
    place,
    record,
    recorded,
    start,
    stop,
)
from openpendant.runtime.bench.bench_path_fidelity import linear_plans
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import quick
from openpendant.runtime.interfaces.device import DeviceIdentity
from openpendant.runtime.interfaces.robot import (
    CommandMode,
    CommandModeRequest,
    JogJointCommand,
    JointTrajectory,
    TrajectoryState,
)
from openpendant.runtime.motion.executor import trajectory as as_trajectory
from openpendant.runtime.motion.moves import MovePlanner
from openpendant.runtime.robotics.deviation import distances_to_polyline
from openpendant.runtime.robotics.robot_info import load_robot_info
from openpendant.runtime.robotics.world import World

FIGURES = (
    "ur_state_rate",
    "ur_jog_command_latency_p50",
    "ur_jog_command_latency_p99",
    "path_deviation_ur_max_mm",
)
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


@contextlib.asynccontextmanager
async def driven(host: str) -> AsyncIterator[URDriver]:
    """A UR5e driver on the emulator at `host`, connected and enabled."""
    info = load_robot_info("ur5e")
    # As in the driver's host: no full collection over what is loaded stalls the control
    # thread past the RTDE watchdog (`run` unfreezes it all, to end with the process).
    gc.collect()
    gc.freeze()
    driver = URDriver(
        DeviceIdentity(uuid="bench-ur", kind="robot", model=info.model, name="ur"), info, host
    )
    await driver.start()
    try:
        await _wait(lambda: not driver.state().flags.communication_failure)
        await driver.enable()
        yield driver
    finally:
        await driver.shutdown()


async def _measure(presses: int, seconds: float) -> tuple[float, list[float]]:
    async with driven(HOST) as driver:
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


async def linear_deviations(host: str, limit: int | None = None) -> dict[str, float]:
    """bench_path_fidelity's linear moves on the UR5e (at most `limit` directions and the
    one out to the edge of its reach), each from home, run through the driver on the
    emulator at `host`, which records its arm's joint positions every cycle (2 ms): each
    move's largest TCP distance (m) from its straight line. Everything is planned before
    the driver starts (the planner holds the interpreter for up to 0.2 s at a time, and the
    driver's control thread feeds the controller's 100 ms watchdog); the emulator puts its
    arm back home, at rest, between moves."""
    info = load_robot_info("ur5e")
    world = World()
    world.add_robot("r", info)
    planner = MovePlanner(world, "r", None)  # automatic mode: no TCP cap
    home = np.array(info.home)
    plans = linear_plans(planner, home, limit)
    deviations = {}
    async with driven(host) as driver:
        await driver.set_command_mode(CommandModeRequest(mode=CommandMode.trajectory))
        for what, _, timed in plans:
            await _wait(lambda: max(abs(v) for v in emulated(host)["qd"]) == 0.0)
            await asyncio.to_thread(place, host, home.tolist())
            await _wait(lambda: np.array_equal(driver.state().joint_position, home))
            await asyncio.to_thread(record, host)
            await _execute(driver, as_trajectory(timed))
            positions = np.array(await asyncio.to_thread(recorded, host))
            tcp = np.array([planner.kinematics.tcp(q).translation for q in positions])
            line = np.array(
                [planner.kinematics.tcp(q).translation for q in (home, timed.positions[-1])]
            )
            deviations[what] = float(np.max(distances_to_polyline(line, tcp)))
    return deviations


async def _execute(driver: URDriver, trajectory: JointTrajectory) -> None:
    accepted = await driver.execute_trajectory(trajectory)
    status = await driver.trajectory_status(accepted.id)
    for _ in range(int(60 / 0.01)):  # about a minute: the longest move takes seconds
        if status.state is not TrajectoryState.running:
            break
        await asyncio.sleep(0.01)
        status = await driver.trajectory_status(accepted.id)
    if status.state is not TrajectoryState.finished:
        raise RuntimeError(f"the UR trajectory ended {status.state.value}: {status.message}")


def run() -> list[Figure]:
    emulator = start(HOST)
    try:
        presses = 20 if quick() else 200
        rate, latencies = asyncio.run(_measure(presses, 1.0 if quick() else 3.0))
        deviations = asyncio.run(linear_deviations(HOST, 2 if quick() else None))
    finally:
        stop(emulator)
        gc.unfreeze()
    details = {"path": "URDriver → ur-rtde → RTDE on loopback → emulator (500 Hz e-Series)"}
    worst = max(deviations.values())
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
        Figure(
            "path_deviation_ur_max_mm",
            worst * 1000,
            "mm",
            target="≤ 2 mm",
            meets_target=worst * 1000 <= 2.0,
            details={
                **details,
                "mode": "automatic, speed 1, acceleration 1",
                "measured": "the emulated controller's joint positions every 2 ms cycle: "
                "TCP distance from the straight line",
                "per_move_mm": {what: round(d * 1000, 4) for what, d in deviations.items()},
            },
        ),
    ]
