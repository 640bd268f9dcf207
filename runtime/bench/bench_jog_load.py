"""Hold-to-run while 200 HTTP clients load the API (DESIGN.md §6: nothing may delay a stop,
and a held jog must not halt for no reason):

- false halts: presses held with a heartbeat every 25 ms (as the UI sends) that the jog
  service halted anyway, for want of heartbeats the gateway held back;
- halt p99: from the last heartbeat of a press whose client goes quiet to the halt at the
  driver (the 100 ms window included), under the same load.

The load runs in its own process, niced, as clients elsewhere on the network would."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from openpendant.runtime.bench.bench_jog import driver_time
from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import Runtime, child_env
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import percentile, quick

FIGURES = ("jog_deadman_under_load_false_halts", "jog_deadman_under_load_halt_p99")
CLIENTS = 200
HEARTBEAT = 0.025


def held(jog: JogClient, seconds: float, direction: int) -> tuple[bool, float]:
    """A press held for `seconds`; True when it was halted while held; the worst gap."""
    press = jog.press(kind="joint", axis=5, direction=direction, speed=0.05)
    end = time.monotonic() + seconds
    last = time.monotonic()
    worst = 0.0
    halted = False
    while time.monotonic() < end:
        time.sleep(HEARTBEAT)
        now = time.monotonic()
        worst = max(worst, now - last)
        last = now
        jog.send({"type": "heartbeat", "press": press})
        jog.drain(0.0)
        if any(m.get("press") == press and m.get("state") == "halted" for m in jog.messages):
            halted = True
            break
    jog.send({"type": "release", "press": press})
    jog.status(press, ("stopped", "halted", "done", "refused"), timeout=5)
    jog.messages.clear()
    return halted, worst


def dropped(cell: Cell, jog: JogClient, direction: int) -> float:
    """A press whose client goes quiet: ms from its last heartbeat to the driver's halt."""
    after = cell.robot.last_command_seq()
    press = jog.press(kind="joint", axis=5, direction=direction, speed=0.05)
    for _ in range(6):
        time.sleep(HEARTBEAT)
        jog.send({"type": "heartbeat", "press": press})
    last_beat = time.time()
    jog.status(press, ("halted", "refused"), timeout=5)
    jog.messages.clear()
    return (driver_time(cell, after, f"{press}:halt") - last_beat) * 1000


def run() -> list[Figure]:
    seconds = 5.0 if quick() else 30.0
    home = Path(tempfile.mkdtemp(prefix="bench-jog-load-"))
    runtime = Runtime(home)
    halts: list[float] = []
    false_halts = presses = 0
    worst_gap = 0.0
    try:
        runtime.wait_ready()
        cell = Cell(runtime)
        cell.ready()
        jog = JogClient(runtime, token=cell.token)
        load = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "openpendant.runtime.bench.load",
                runtime.url,
                str(seconds),
                str(CLIENTS),
            ],
            stdout=subprocess.PIPE,
            env=child_env(home, OPENPENDANT_TOKEN=runtime.token("viewer")),
            preexec_fn=lambda: os.nice(10),
        )
        try:
            time.sleep(1.0)  # the load is up
            end = time.monotonic() + seconds - 1.5
            k = 0
            while time.monotonic() < end:
                k += 1
                halted, gap = held(jog, 0.6, 1 if k % 2 else -1)
                presses += 1
                false_halts += int(halted)
                worst_gap = max(worst_gap, gap)
                halts.append(dropped(cell, jog, -1 if k % 2 else 1))
            assert load.stdout is not None
            answered = json.loads(load.stdout.readline() or "{}")
        finally:
            load.wait(60)
            jog.close()
    finally:
        runtime.stop()
    details = {
        "clients": CLIENTS,
        "seconds": seconds,
        "presses": presses,
        "heartbeat_ms": HEARTBEAT * 1000,
        "client_worst_heartbeat_gap_ms": round(worst_gap * 1000, 1),
        "deadman_window_ms": 100,
        "load": answered,
    }
    return [
        Figure(
            "jog_deadman_under_load_false_halts",
            float(false_halts),
            "count",
            "0",
            false_halts == 0,
            details,
        ),
        Figure(
            "jog_deadman_under_load_halt_p99",
            percentile(halts, 99),
            "ms",
            "≤ 120 ms",
            percentile(halts, 99) <= 120,
            {"trials": len(halts), "max": max(halts) if halts else None},
        ),
    ]
