"""Period error of the simulated robot's 500 Hz control loop (target p99 ≤ 1 ms), measured
while the driver also streams its state and takes jog commands, as in use; and what one of
its control cycles along a planned trajectory costs."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import websockets

from openpendant.device_drivers.sim_robot.core import CYCLE, SimCore
from openpendant.runtime.bench.harness.processes import SimRobotProc
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import quick
from openpendant.runtime.interfaces.limits import JointLimitChecker
from openpendant.runtime.interfaces.robot import CommandMode, JointTrajectory, TrajectoryWaypoint
from openpendant.runtime.robotics.kinematics import Kinematics
from openpendant.runtime.robotics.robot_info import load_robot_info

FIGURES = (
    "sim_loop_period_error_p99",
    "sim_loop_period_error_max",
    "host_timer_jitter_p99",
    "sim_trajectory_cycle_p50",
)
# Five cycles a period (the tests' faster clock, OPENPENDANT_SIM_TIME_SCALE=5) must leave
# most of the 2 ms period to the state stream and the commands.
TRAJECTORY_CYCLE_TARGET = 200.0  # µs

# The same 2 ms sleep loop with nothing else in the process: how much of the period error
# is the host's own (a VM's timer wake-ups can be late by milliseconds).
BARE_LOOP = """
import sys, time
n = int(sys.argv[1]); last = time.perf_counter(); deadline = last; errors = []
for _ in range(n):
    deadline += 0.002
    delay = deadline - time.perf_counter()
    if delay > 0:
        time.sleep(delay)
    now = time.perf_counter(); errors.append(abs(now - last - 0.002) * 1000); last = now
errors.sort(); print(errors[int(len(errors) * 0.99)])
"""


def host_jitter_p99(seconds: float) -> float:
    result = subprocess.run(
        [sys.executable, "-c", BARE_LOOP, str(int(seconds / 0.002))],
        capture_output=True,
        text=True,
        check=True,
    )
    return float(result.stdout)


async def load(url: str, seconds: float, signed: dict[str, str]) -> None:
    """Three state subscribers and a 50 Hz jog stream back and forth on joint 1."""
    ws_url = url.replace("http://", "ws://")

    async def subscriber() -> None:
        async with websockets.connect(f"{ws_url}/state/ws") as ws:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                json.loads(await ws.recv())

    async def jogger() -> None:
        async with websockets.connect(f"{ws_url}/command/ws", additional_headers=signed) as ws:
            end = time.monotonic() + seconds
            k = 0
            while time.monotonic() < end:
                v = 0.5 if (k // 50) % 2 == 0 else -0.5
                await ws.send(
                    json.dumps(
                        {"type": "jog_joint", "velocity": [v, 0, 0, 0, 0, 0], "timeout": 0.1}
                    )
                )
                k += 1
                await asyncio.sleep(0.02)

    await asyncio.gather(subscriber(), subscriber(), subscriber(), jogger())


def trajectory_cycle(cycles: int) -> tuple[float, float]:
    """p50 and p99 (µs) of one control cycle of a simulated UR5 following an 8 s joint
    trajectory of 400 waypoints, as the motion service sends one; in this process, with
    nothing else running."""
    info = load_robot_info("ur5")
    core = SimCore(info, Kinematics(info))
    core.enable()
    core.set_mode(CommandMode.trajectory)
    start = core.tracker.position.copy()
    goal = start + np.array([0.8, -0.4, 0.6, 0.2, -0.2, 1.0])
    count = 400
    waypoints = [
        TrajectoryWaypoint(
            time_from_start=8.0 * (i + 1) / count,
            position=list(start + (goal - start) * 0.5 * (1 - np.cos(np.pi * (i + 1) / count))),
        )
        for i in range(count)
    ]
    checked = JointLimitChecker(info).trajectory(JointTrajectory(waypoints=waypoints), start)
    core.start_trajectory(checked)
    now, took = 0.0, []
    for _ in range(cycles):
        now += CYCLE
        begin = time.perf_counter()
        core.step(now)
        took.append((time.perf_counter() - begin) * 1e6)
    return float(np.percentile(took, 50)), float(np.percentile(took, 99))


def run() -> list[Figure]:
    seconds = 3.0 if quick() else 15.0
    home = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    sim = SimRobotProc(home, name="bench-loop")
    try:
        sim.wait_ready()
        with sim.client() as robot:
            robot.post("/enable").raise_for_status()
            robot.put("/command_mode", json={"mode": "jog"}).raise_for_status()
            time.sleep(0.5)
            robot.delete("/sim/loop_stats").raise_for_status()
            asyncio.run(load(sim.url, seconds, sim.signed("/command/ws")))
            stats = robot.get("/sim/loop_stats").json()
    finally:
        sim.stop()
    p99 = float(stats["error_p99_ms"])
    host = host_jitter_p99(seconds)
    details = {k: stats[k] for k in ("cycles", "error_p50_ms", "overruns")}
    details["load"] = "3 state subscribers at 100 Hz + jog commands at 50 Hz"
    cycle_p50, cycle_p99 = trajectory_cycle(1000 if quick() else 3000)
    return [
        Figure("sim_loop_period_error_p99", p99, "ms", "≤ 1 ms", p99 <= 1.0, details),
        Figure("sim_loop_period_error_max", float(stats["error_max_ms"]), "ms"),
        Figure(
            "host_timer_jitter_p99",
            host,
            "ms",
            details={"measured": "a bare 2 ms sleep loop in its own process, right after"},
        ),
        Figure(
            "sim_trajectory_cycle_p50",
            cycle_p50,
            "µs",
            f"≤ {TRAJECTORY_CYCLE_TARGET:.0f} µs",
            cycle_p50 <= TRAJECTORY_CYCLE_TARGET,
            {"p99_us": round(cycle_p99, 1), "trajectory": "UR5, 8 s, 400 waypoints"},
        ),
    ]
