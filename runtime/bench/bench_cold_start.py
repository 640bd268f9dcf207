"""Whole runtime: cold start (≤ 5 s) and memory (total PSS ≤ 400 MB), at rest after start and
again after it has worked (a planned move, a held jog): the children are forked from the
launcher and share its pages until they write to them, so memory is measured both ways."""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from openpendant.runtime.bench.harness.jog import Cell, JogClient
from openpendant.runtime.bench.harness.processes import Runtime
from openpendant.runtime.bench.runner import Figure
from openpendant.runtime.bench.stats import quick

FIGURES = ("cold_start", "total_rss", "total_pss", "total_pss_after_work")
PSS_TARGET = 400.0  # MB


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


def total_mb(pid: int, field: str) -> float:
    return sum(memory_kb(p, field) for p in descendants(pid)) / 1024


def work(runtime: Runtime) -> None:
    """What a cell does first: a robot added, a planned move, a held Cartesian jog."""
    cell = Cell(runtime)
    cell.ready()
    cell.place([0.3, -1.4, 1.6, -1.8, -1.57, 0.0])
    jog = JogClient(runtime, token=cell.token)
    try:
        jog.hold(1.0, kind="cartesian", axis="z", direction=1, frame="base", speed=0.3)
    finally:
        jog.close()
    cell.robot.wait_stopped()


def run() -> list[Figure]:
    trials = 1 if quick() else 3
    starts: list[float] = []
    rss_mb = pss_mb = worked_mb = 0.0
    processes = 0
    for _ in range(trials):
        home = Path(tempfile.mkdtemp(prefix="bench-start-"))
        t0 = time.monotonic()
        runtime = Runtime(home)
        try:
            runtime.wait_ready()
            starts.append(time.monotonic() - t0)
            time.sleep(2.0)  # the simulated robot is up and everything has settled
            processes = len(descendants(runtime.pid))
            rss_mb = total_mb(runtime.pid, "RSS")
            pss_mb = total_mb(runtime.pid, "Pss")
            work(runtime)
            worked_mb = total_mb(runtime.pid, "Pss")
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
            details={
                "processes": processes,
                "note": "sum of RSS: a page the children share with the launcher counts "
                "once in every process that maps it, so this overstates what is used; "
                "total_pss divides each shared page among the processes sharing it",
            },
        ),
        Figure(
            "total_pss",
            pss_mb,
            "MB",
            f"≤ {PSS_TARGET:.0f} MB",
            pss_mb <= PSS_TARGET,
            {"processes": processes, "measured": "2 s after start, at rest"},
        ),
        Figure(
            "total_pss_after_work",
            worked_mb,
            "MB",
            f"≤ {PSS_TARGET:.0f} MB",
            worked_mb <= PSS_TARGET,
            {"measured": "after a robot was added, moved by a planned move and jogged"},
        ),
    ]
