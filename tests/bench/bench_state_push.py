"""Robot state pushed to UI clients: ≥ 50 Hz per robot with 10 clients, lag ≤ 20 ms.

Ten clients hold the same socket the UI uses (/api/devices/ws through the webui) while two
simulated robots are added. Lag is the client's receive time minus the state's own time
stamp (taken by the driver when it sampled the state; same machine, same clock)."""

from __future__ import annotations

import asyncio
import json
import tempfile
import time
from collections import defaultdict
from functools import partial
from pathlib import Path

import websockets

from tests.bench.runner import Figure
from tests.bench.stats import percentile, quick
from tests.support.processes import Runtime, SimRobotProc, wait_for

FIGURES = ("state_push_rate", "state_push_lag_p99", "state_push_lag_p50")
CLIENTS = 10


async def client(url: str, seconds: float) -> tuple[dict[str, int], list[float]]:
    counts: dict[str, int] = defaultdict(int)
    lags: list[float] = []
    async with websockets.connect(url, max_size=2**22) as ws:
        await asyncio.sleep(0.5)  # let every client join before counting
        while True:  # drain what queued while joining
            try:
                await asyncio.wait_for(ws.recv(), 0.001)
            except TimeoutError:
                break
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            message = json.loads(await ws.recv())
            if message["type"] == "state":
                lags.append((time.time() - message["state"]["ts"]) * 1000.0)
                counts[message["device"]] += 1
    return counts, lags


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
        url = runtime.url.replace("http://", "ws://") + "/api/devices/ws"

        async def everyone() -> list[tuple[dict[str, int], list[float]]]:
            return await asyncio.gather(*(client(url, seconds) for _ in range(CLIENTS)))

        results = asyncio.run(everyone())
    finally:
        second.stop()
        runtime.stop()
    rates = [count / seconds for counts, _ in results for count in counts.values()]
    lags = [lag for _, client_lags in results for lag in client_lags]
    rate = min(rates) if len(rates) == 2 * CLIENTS else 0.0
    p99 = percentile(lags, 99)
    details = {
        "clients": CLIENTS,
        "robots": 2,
        "seconds": seconds,
        "rate_mean_hz": sum(rates) / max(len(rates), 1),
        "driver_rate_hz": 100,
        "lag_max_ms": max(lags, default=float("nan")),
    }
    return [
        Figure("state_push_rate", rate, "Hz per robot", "≥ 50 Hz", rate >= 50, details),
        Figure("state_push_lag_p99", p99, "ms", "≤ 20 ms", p99 <= 20),
        Figure("state_push_lag_p50", percentile(lags, 50), "ms"),
    ]
