"""New device on the network → listed as detected (target ≤ 1 s)."""

from __future__ import annotations

import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick

FIGURES = ("discovery_time", "discovery_from_process_start")


def run() -> list[Figure]:
    trials = 3 if quick() else 10
    home = Path(tempfile.mkdtemp(prefix="bench-discovery-"))
    runtime = Runtime(home, extra=["--no-sim"])
    announced: list[float] = []
    spawned: list[float] = []
    try:
        runtime.wait_ready()
        for i in range(trials):
            t_spawn = time.monotonic()
            sim = SimRobotProc(home, name=f"bench-{i}")
            try:
                sim.wait_ready()  # printed as the driver starts announcing itself
                t_announce = time.monotonic()
                wait_for(
                    partial(runtime.is_detected, sim.uuid), 10, interval=0.002, what="detected"
                )
                now = time.monotonic()
                announced.append(now - t_announce)
                spawned.append(now - t_spawn)
            finally:
                sim.stop()
    finally:
        runtime.stop()
    median = statistics.median(announced)
    return [
        Figure(
            "discovery_time",
            median,
            "s",
            "≤ 1 s",
            median <= 1.0,
            {
                "trials": trials,
                "p90": percentile(announced, 90),
                "max": max(announced),
                "measured": "driver announces itself → listed by GET /api/devices/detected",
            },
        ),
        Figure(
            "discovery_from_process_start",
            statistics.median(spawned),
            "s",
            details={
                "measured": "`openpendant sim-robot` spawned → listed (includes the "
                "driver's Python start-up)"
            },
        ),
    ]
