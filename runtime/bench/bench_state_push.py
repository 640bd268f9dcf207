"""Robot state pushed to UI clients: ≥ 50 Hz per robot with 10 clients, lag ≤ 20 ms.

Ten clients hold the feed as the UI does (/api/devices/ws?batch=1 through the webui, each
frame acknowledged at the next 60 Hz display frame; runtime/bench/ui_clients.py) while two
simulated robots are added. Lag is the client's receive time minus the state's own time
stamp (taken by the driver when it sampled the state; same machine, same clock)."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from functools import partial
from pathlib import Path

from openpendant.runtime.bench.harness.processes import Runtime, SimRobotProc, child_env, wait_for
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick

FIGURES = ("state_push_rate", "state_push_lag_p99", "state_push_lag_p50")
CLIENTS = 10


def run() -> list[Figure]:
    seconds = 3.0 if quick() else 10.0
    home = Path(tempfile.mkdtemp(prefix="bench-push-"))
    runtime = Runtime(home)
    second = SimRobotProc(home, name="bench-second")
    try:
        runtime.wait_ready()
        second.wait_ready()
        for name, uuid in (("robot", None), ("robot2", second.uuid)):
            found = wait_for(lambda: runtime.api("GET", "/devices/detected").json(), 10)
            uuid = uuid or next(d["uuid"] for d in found if d["name"] == "sim-ur5")
            wait_for(partial(runtime.is_detected, uuid), 10)
            response = runtime.api("POST", "/devices", json={"uuid": uuid, "local_name": name})
            response.raise_for_status()
        wait_for(
            lambda: all(d["status"] == "connected" for d in runtime.api("GET", "/devices").json()),
            10,
        )
        url = runtime.url.replace("http://", "ws://") + "/api/devices/ws?batch=1"
        clients = subprocess.run(
            [
                sys.executable,
                "-m",
                "openpendant.runtime.bench.ui_clients",
                url,
                str(CLIENTS),
                str(seconds),
            ],
            capture_output=True,
            text=True,
            env=child_env(home, OPENPENDANT_TOKEN=runtime.token("viewer")),
            check=True,
        )
        results = json.loads(clients.stdout)
    finally:
        second.stop()
        runtime.stop()
    rates = [count / seconds for result in results for count in result["counts"].values()]
    lags = [lag for result in results for lag in result["ages"]]
    rate = min(rates) if len(rates) == 2 * CLIENTS else 0.0
    p99 = percentile(lags, 99)
    details = {
        "clients": CLIENTS,
        "robots": 2,
        "seconds": seconds,
        "rate_mean_hz": sum(rates) / max(len(rates), 1),
        "driver_rate_hz": 100,
        "client_display_hz": 60,
        "lag_max_ms": max(lags, default=float("nan")),
    }
    return [
        Figure("state_push_rate", rate, "Hz per robot", "≥ 50 Hz", rate >= 50, details),
        Figure("state_push_lag_p99", p99, "ms", "≤ 20 ms", p99 <= 20),
        Figure("state_push_lag_p50", percentile(lags, 50), "ms"),
    ]
