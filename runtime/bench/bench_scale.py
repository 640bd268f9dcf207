"""Many robots, many UI clients (DESIGN.md §9: 20 robots, 10 UI clients, every robot ≥ 50 Hz
at the UI, state age p99 ≤ 50 ms):

Simulated robots at their normal rate (500 Hz control, 100 Hz state), niced as if on other
hosts, are added to one runtime: 1, then 5, 10 and 20. At each count, 10 UI clients hold the
device feed as the browser does (runtime/bench/ui_clients.py, their own process) for a while:
the slowest robot's state rate at a client, and the age of every state on arrival (driver
timestamp to client; one machine, one clock). CPU and RSS of every runtime process go in the
details. The curve ends where this host cannot keep every link fresh, or where a UI client
fails: what was measured until then (at that count, by the clients that did not fail) is
reported, and why it stopped (which client, the exit status and stderr of their process)."""

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

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, child_env, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick

FIGURES = (
    "scale_20_robots_min_rate",
    "scale_20_robots_age_p50",
    "scale_20_robots_age_p99",
    "scale_robots_curve",
)
CLIENTS = 10
COUNTS = (1, 5, 10, 20)
TICK = os.sysconf("SC_CLK_TCK")
STDERR_TAIL = 2000  # characters of a failed UI-client process's stderr kept
CLIENTS_GRACE = 60.0  # s the UI-client process may take beyond its measuring time


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


def run_clients(
    url: str, robots: int, seconds: float, env: dict[str, str], clients: int = CLIENTS
) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """The UI clients' figures at this robot count, from the clients that did not fail (None
    when none did), and the failure (None when there was none)."""
    argv = [
        sys.executable,
        "-m",
        "openpendant.runtime.bench.ui_clients",
        url,
        str(clients),
        str(seconds),
    ]
    try:
        done = subprocess.run(
            argv, capture_output=True, text=True, env=env, timeout=seconds + CLIENTS_GRACE
        )
        status: int | str = done.returncode
        stdout, stderr = done.stdout, done.stderr
    except subprocess.TimeoutExpired as exc:  # killed by run()
        status = f"killed after {seconds + CLIENTS_GRACE:.0f} s"
        stdout, stderr = text_of(exc.stdout), text_of(exc.stderr)
    try:
        report: list[dict[str, Any]] = json.loads(stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):  # it died before reporting
        report = []
    finished = [r for r in report if "error" not in r]
    failed = [{"client": r["client"], "error": r["error"]} for r in report if "error" in r]
    failure = None
    if status != 0 or failed or len(finished) < clients:
        failure = {
            "robots": robots,
            "clients": clients,
            "clients_measured": len(finished),
            "failed_clients": failed,
            "exit_status": status,
            "stderr_tail": stderr[-STDERR_TAIL:],
        }
    if not finished:
        return None, failure
    rates = [r["counts"].get(f"r{k}", 0) / seconds for r in finished for k in range(robots)]
    ages = [age for r in finished for age in r["ages"]]
    point = {
        "robots": robots,
        "clients_measured": len(finished),
        "min_rate_hz": round(min(rates), 1),
        "mean_rate_hz": round(sum(rates) / len(rates), 1),
        "age_p50_ms": round(percentile(ages, 50), 2),
        "age_p99_ms": round(percentile(ages, 99), 2),
        "age_max_ms": round(max(ages), 1) if ages else None,
    }
    if failure is not None:
        point["failed_clients"] = [f["client"] for f in failed]
    return point, failure


def text_of(output: str | bytes | None) -> str:
    if isinstance(output, bytes):
        return output.decode(errors="replace")
    return output or ""


def why(failure: dict[str, Any]) -> str:
    """A failure of the UI clients, in a line."""
    clients, measured = failure["clients"], failure["clients_measured"]
    failed = failure["failed_clients"]
    if failed:
        which = "; ".join(
            f"UI client {f['client']} of {clients} failed: {f['error']}" for f in failed
        )
    elif measured < clients:
        which = f"the UI-client process reported figures for {measured} of its {clients} clients"
    else:
        which = "the UI-client process failed after reporting its figures"
    return f"at {failure['robots']} robots: {which} (exit status {failure['exit_status']})"


def measure(
    runtime: Runtime, robots: int, seconds: float, home: Path
) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    pids = runtime_pids(runtime)
    before = {name: cpu_seconds(pid) for name, pid in pids.items()}
    started = time.monotonic()
    url = runtime.url.replace("http://", "ws://") + "/api/devices/ws?batch=1"
    env = child_env(home, OPENPENDANT_TOKEN=runtime.token("viewer"))
    point, failure = run_clients(url, robots, seconds, env)
    elapsed = time.monotonic() - started
    if point is not None:
        point["cpu_percent"] = {
            name: round(100 * (cpu_seconds(pid) - before[name]) / elapsed, 1)
            for name, pid in pids.items()
        }
        point["rss_mb"] = {name: round(rss_mb(pid), 1) for name, pid in pids.items()}
    return point, failure


def meets(point: dict[str, Any]) -> bool:
    return bool(
        point["min_rate_hz"] >= 50 and point["age_p99_ms"] <= 50 and not point.get("failed_clients")
    )


def run() -> list[Figure]:
    seconds = 3.0 if quick() else 10.0
    counts = (1, 3) if quick() else COUNTS
    home = Path(tempfile.mkdtemp(prefix="bench-scale-"))
    runtime = Runtime(home, extra=["--no-sim"])
    sims: list[SimRobotProc] = []
    curve: list[dict[str, Any]] = []
    stopped = ""
    failure: dict[str, Any] | None = None
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
            point, failure = measure(runtime, count, seconds, home)
            if point is not None:
                curve.append(point)
                print(f"  {count} robots: {point}", file=sys.stderr, flush=True)
            if failure is not None:
                stopped = why(failure)
                print(f"  {stopped}\n{failure['stderr_tail']}", file=sys.stderr, flush=True)
                break
    finally:
        for sim in sims:
            sim.stop()
        runtime.stop()
    return figures(curve, counts[-1], seconds, stopped, failure)


def figures(
    curve: list[dict[str, Any]],
    wanted: int,
    seconds: float,
    stopped: str = "",
    failure: dict[str, Any] | None = None,
) -> list[Figure]:
    """The figures of the curve measured, up to `wanted` robots; `stopped`: why it ended
    short, with the UI clients' `failure` when that was why."""
    if not curve:  # not even the first count could be measured
        nothing = {"robots": 0, "min_rate_hz": 0.0, "age_p50_ms": math.nan, "age_p99_ms": math.nan}
        curve = [nothing]
    top = curve[-1]
    details = {**top, "clients": CLIENTS, "seconds": seconds, "simulators": "nice 10"}
    if stopped:
        details["stopped"] = stopped
    if failure is not None:
        details["client_failure"] = failure
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
            bool(met) and max(met) == wanted,
            {"curve": curve},
        ),
    ]
