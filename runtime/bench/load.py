"""Many HTTP clients hammering the runtime's API, from a process of their own (niced: they
stand for tablets and laptops elsewhere on the network):

python -m openpendant.runtime.bench.load URL SECONDS CLIENTS

Each client loops over a mix of the UI's reads. Prints one JSON line at the end: requests
answered, errors, and the p50/p99 response time (ms)."""

from __future__ import annotations

import asyncio
import json
import os
import sys
import time

import httpx
import numpy as np

PATHS = (
    "/api/devices",
    "/api/devices/detected",
    "/api/devices/robot/state",
    "/api/variables",
    "/api/programs",
    "/api/jog/settings",
    "/api/health",
)


async def client(http: httpx.AsyncClient, end: float, k: int, times: list[float]) -> int:
    errors = 0
    n = k
    while time.monotonic() < end:
        started = time.monotonic()
        try:
            response = await http.get(PATHS[n % len(PATHS)])
            if response.status_code >= 500:
                errors += 1
        except httpx.HTTPError:
            errors += 1
        times.append((time.monotonic() - started) * 1000)
        n += 1
    return errors


async def main(url: str, seconds: float, clients: int) -> None:
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients)
    times: list[float] = []
    token = os.environ.get("OPENPENDANT_TOKEN")
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    async with httpx.AsyncClient(
        base_url=url, limits=limits, timeout=30.0, headers=headers
    ) as http:
        end = time.monotonic() + seconds
        errors = await asyncio.gather(*(client(http, end, k, times) for k in range(clients)))
    print(
        json.dumps(
            {
                "requests": len(times),
                "errors": sum(errors),
                "p50_ms": float(np.percentile(times, 50)) if times else None,
                "p99_ms": float(np.percentile(times, 99)) if times else None,
            }
        ),
        flush=True,
    )


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3])))
