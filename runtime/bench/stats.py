"""Small statistics helpers for benchmarks."""

from __future__ import annotations

import os

import numpy as np


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if values else float("nan")


def quick() -> bool:
    """OPENPENDANT_BENCH_QUICK=1 shortens every benchmark (used by the runner's own test)."""
    return os.environ.get("OPENPENDANT_BENCH_QUICK") == "1"


def cpu_times() -> list[int]:
    """The machine's CPU counters (user nice system idle iowait irq softirq steal ...)."""
    with open("/proc/stat") as stat:
        return [int(v) for v in stat.readline().split()[1:]]


def steal_percent(before: list[int], after: list[int]) -> float:
    """Share of CPU time the hypervisor took from this VM between two readings."""
    delta = [b - a for a, b in zip(before, after, strict=True)]
    total = sum(delta[:8])
    return round(100.0 * delta[7] / total, 1) if total else 0.0
