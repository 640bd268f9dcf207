"""Whole runtime: cold start (≤ 5 s) and memory (total ≤ 600 MB)."""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from runtime.bench.harness.processes import Runtime
from runtime.bench.runner import Figure
from runtime.bench.stats import quick

FIGURES = ("cold_start", "total_rss", "total_pss")


def descendants(pid: int) -> list[int]:
    found = [pid]
    for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split():
        found.extend(descendants(int(child)))
    return found


def memory_kb(pid: int, field: str) -> int:
    source = "smaps_rollup" if field == "Pss" else "status"
    for line in Path(f"/proc/{pid}/{source}").read_text().splitlines():
        if line.startswith(f"{field}:") or line.startswith(f"Vm{field}:"):
            return int(line.split()[1])
    return 0


def run() -> list[Figure]:
    trials = 1 if quick() else 3
    starts: list[float] = []
    rss_mb = pss_mb = 0.0
    processes = 0
    for _ in range(trials):
        home = Path(tempfile.mkdtemp(prefix="bench-start-"))
        t0 = time.monotonic()
        runtime = Runtime(home)
        try:
            runtime.wait_ready()
            starts.append(time.monotonic() - t0)
            time.sleep(2.0)  # the simulated robot is up and everything has settled
            pids = descendants(runtime.pid)
            processes = len(pids)
            rss_mb = sum(memory_kb(p, "RSS") for p in pids) / 1024
            pss_mb = sum(memory_kb(p, "Pss") for p in pids) / 1024
        finally:
            runtime.stop()
    start = statistics.median(starts)
    return [
        Figure(
            "cold_start",
            start,
            "s",
            "≤ 5 s",
            start <= 5.0,
            {
                "trials": trials,
                "all": starts,
                "measured": "`openpendant run` spawned → prints the UI URL with all services "
                "healthy",
            },
        ),
        Figure(
            "total_rss",
            rss_mb,
            "MB",
            "≤ 600 MB",
            rss_mb <= 600,
            {
                "processes": processes,
                "note": "sum of RSS; shared pages count once per "
                "process, so this overstates; see total_pss",
            },
        ),
        Figure("total_pss", pss_mb, "MB", details={"processes": processes}),
    ]
