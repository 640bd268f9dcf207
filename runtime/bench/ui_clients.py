"""UI clients of the device feed, as browsers hold it (/api/devices/ws?batch=1 through the
webui, each frame acknowledged at the next 60 Hz display frame), from a process of their
own: python -m openpendant.runtime.bench.ui_clients URL CLIENTS SECONDS

Prints one JSON line: per client (numbered from 0), the states received per device, and
every state's age at arrival (ms: arrival time minus the driver's own timestamp; same
machine, same clock), or, for a client that failed, why. A failure does not end the other
clients; its traceback goes to stderr and the exit status is 1."""

from __future__ import annotations

import asyncio
import json
import os
import re
import sys
import time
import traceback
from collections import defaultdict
from typing import Any

import websockets

STATE = re.compile(r'"device":"([^"]+)","ts":[^,]+,"state":\{"seqno":\d+,"ts":([-+0-9.eE]+)')
DISPLAY = 1 / 60  # s per frame a browser draws
ACK = '{"type":"ack"}'


def auth() -> dict[str, str]:
    """Signed in as the benchmark's caller says (a viewer's API token)."""
    token = os.environ.get("OPENPENDANT_TOKEN")
    return {"Authorization": f"Bearer {token}"} if token else {}


async def client(url: str, seconds: float) -> tuple[dict[str, int], list[float]]:
    counts: dict[str, int] = defaultdict(int)
    ages: list[float] = []
    async with websockets.connect(url, max_size=2**24, additional_headers=auth()) as ws:
        unacked = 0

        async def display() -> None:
            nonlocal unacked
            while True:
                await asyncio.sleep(DISPLAY)
                for _ in range(unacked):
                    await ws.send(ACK)
                unacked = 0

        drawing = asyncio.create_task(display())
        start = time.monotonic() + 1.0  # every client has joined
        end = start + seconds
        try:
            while time.monotonic() < end:
                frame = await ws.recv()
                now = time.time()
                unacked += 1
                if time.monotonic() < start:
                    continue
                text = frame if isinstance(frame, str) else frame.decode()
                for device, ts in STATE.findall(text):
                    counts[device] += 1
                    ages.append((now - float(ts)) * 1000.0)
        finally:
            drawing.cancel()
    return counts, ages


async def main(url: str, clients: int, seconds: float) -> int:
    results = await asyncio.gather(
        *(client(url, seconds) for _ in range(clients)), return_exceptions=True
    )
    report: list[dict[str, Any]] = []
    for number, result in enumerate(results):
        if isinstance(result, BaseException):
            print(f"client {number} failed:", file=sys.stderr)
            traceback.print_exception(result, file=sys.stderr)
            report.append({"client": number, "error": f"{type(result).__name__}: {result}"})
        else:
            counts, ages = result
            report.append({"client": number, "counts": counts, "ages": ages})
    print(json.dumps(report), flush=True)
    return 1 if any("error" in r for r in report) else 0


if __name__ == "__main__":
    sys.exit(asyncio.run(main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]))))
