"""Small statistics helpers for benchmarks."""

from __future__ import annotations

import os

import numpy as np


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if values else float("nan")


def quick() -> bool:
    """OPENPENDANT_BENCH_QUICK=1 shortens every benchmark (used by the runner's own test)."""
    return os.environ.get("OPENPENDANT_BENCH_QUICK") == "1"
