"""Many robots, many UI clients (DESIGN.md §9: 20 robots, 10 UI clients, every robot ≥ 50 Hz
at the UI, state age p99 ≤ 50 ms):

Simulated robots at their normal rate (500 Hz control, 100 Hz state), niced as if on other
hosts, are added to one runtime: 1, then 5, 10 and 20. At each count, 10 UI clients hold the
device feed as the browser does (runtime/bench/ui_clients.py, their own process) for a while:
the slowest robot's state rate at a client, and the age of every state on arrival (driver
timestamp to client; one machine, one clock). CPU and RSS of every runtime process go in the
details."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path
from typing import Any

from runtime.bench.harness.processes import Runtime, SimRobotProc, child_env, wait_for
from runtime.bench.runner import Figure
from runtime.bench.stats import percentile, quick

FIGURES = (
    "scale_20_robots_min_rate",
    "scale_20_robots_age_p50",
    "scale_20_robots_age_p99",
    "scale_robots_curve",
)
CLIENTS = 10
COUNTS = (1, 5, 10, 20)
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


def runtime_pids(runtime: Runtime) -> dict[str, int]:
    services = runtime.api("GET", "/health").json()["services"]
    return {name: int(s["pid"]) for name, s in services.items() if "pid" in s}


def add_robots(runtime: Runtime, sims: list[SimRobotProc], first: int) -> None:
    for k, sim in enumerate(sims[first:], start=first):
        wait_for(partial(runtime.is_detected, sim.uuid), 20, what=f"robot {k} detected")
        added = runtime.api("POST", "/devices", json={"uuid": sim.uuid, "local_name": f"r{k}"})
        added.raise_for_status()
    wait_for(
        lambda: all(d["status"] == "connected" for d in runtime.api("GET", "/devices").json()),
        60,
        what="every robot connected at once",
    )


def measure(runtime: Runtime, robots: int, seconds: float, home: Path) -> dict[str, Any]:
    pids = runtime_pids(runtime)
    before = {name: cpu_seconds(pid) for name, pid in pids.items()}
    started = time.monotonic()
    url = runtime.url.replace("http://", "ws://") + "/api/devices/ws?batch=1"
    clients = subprocess.run(
        [sys.executable, "-m", "runtime.bench.ui_clients", url, str(CLIENTS), str(seconds)],
        capture_output=True,
        text=True,
        env=child_env(home, OPENPENDANT_TOKEN=runtime.token("viewer")),
        check=True,
    )
    elapsed = time.monotonic() - started
    results = json.loads(clients.stdout)
    rates = [
        results[c]["counts"].get(f"r{k}", 0) / seconds
        for c in range(CLIENTS)
        for k in range(robots)
    ]
    ages = [age for result in results for age in result["ages"]]
    return {
        "robots": robots,
        "min_rate_hz": round(min(rates), 1),
        "mean_rate_hz": round(sum(rates) / len(rates), 1),
        "age_p50_ms": round(percentile(ages, 50), 2),
        "age_p99_ms": round(percentile(ages, 99), 2),
        "age_max_ms": round(max(ages), 1) if ages else None,
        "cpu_percent": {
            name: round(100 * (cpu_seconds(pid) - before[name]) / elapsed, 1)
            for name, pid in pids.items()
        },
        "rss_mb": {name: round(rss_mb(pid), 1) for name, pid in pids.items()},
    }


def meets(point: dict[str, Any]) -> bool:
    return bool(point["min_rate_hz"] >= 50 and point["age_p99_ms"] <= 50)


def run() -> list[Figure]:
    seconds = 3.0 if quick() else 10.0
    counts = (1, 3) if quick() else COUNTS
    home = Path(tempfile.mkdtemp(prefix="bench-scale-"))
    runtime = Runtime(home, extra=["--no-sim"])
    sims: list[SimRobotProc] = []
    curve: list[dict[str, Any]] = []
    stopped = ""
    try:
        runtime.wait_ready()
        for count in counts:
            first = len(sims)
            sims += [SimRobotProc(home, f"scale-{k}", nice=10) for k in range(first, count)]
            for sim in sims[first:]:
                sim.wait_ready()
            try:
                add_robots(runtime, sims, first)
            except TimeoutError as exc:
                # This host cannot keep that many links fresh: the curve ends where it got.
                stopped = f"at {count} robots: {exc}"
                print(f"  {count} robots: {stopped}", file=sys.stderr, flush=True)
                break
            time.sleep(1.0)
            curve.append(measure(runtime, count, seconds, home))
            print(f"  {count} robots: {curve[-1]}", file=sys.stderr, flush=True)
    finally:
        for sim in sims:
            sim.stop()
        runtime.stop()
    if not curve:  # not even the first count could be kept fresh
        nothing = {"robots": 0, "min_rate_hz": 0.0, "age_p50_ms": math.nan, "age_p99_ms": math.nan}
        curve.append(nothing)
    top = curve[-1]
    details = {**top, "clients": CLIENTS, "seconds": seconds, "simulators": "nice 10"}
    if stopped:
        details["stopped"] = stopped
    met = [p["robots"] for p in curve if meets(p)]
    return [
        Figure(
            "scale_20_robots_min_rate",
            top["min_rate_hz"],
            "Hz",
            "≥ 50 Hz",
            not stopped and top["min_rate_hz"] >= 50,
            details,
        ),
        Figure("scale_20_robots_age_p50", top["age_p50_ms"], "ms"),
        Figure(
            "scale_20_robots_age_p99",
            top["age_p99_ms"],
            "ms",
            "≤ 50 ms",
            not stopped and top["age_p99_ms"] <= 50,
        ),
        Figure(
            "scale_robots_curve",
            float(max(met, default=0)),
            "robots",
            "20 robots within both targets",
            bool(met) and max(met) == counts[-1],
            {"curve": curve},
        ),
    ]
