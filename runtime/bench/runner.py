"""`openpendant bench`: run the benchmarks, print a table, write the figures as JSON.

Each benchmark module exposes FIGURES (the names it reports) and run() -> list[Figure].
Figure names are stable across versions: checks read them from the JSON.
"""

from __future__ import annotations

import importlib
import json
import platform
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from openpendant.runtime.bench.stats import cpu_times, steal_percent

MODULES = (
    "discovery",
    "state_push",
    "sim_loop",
    "cold_start",
    "jog",
    "jog_load",
    "motion",
    "path_fidelity",
    "program",
    "scale",
    "modbus",
    "io_panel",
    "ur",
    "vision",
    "camera_view",
)


@dataclass
class Figure:
    name: str
    value: float
    unit: str
    target: str = ""
    meets_target: bool | None = None
    details: dict[str, Any] = field(default_factory=dict)


def load(module: str) -> Any:
    return importlib.import_module(f"openpendant.runtime.bench.bench_{module}")


def select(only: list[str] | None) -> list[str]:
    if not only:
        return list(MODULES)
    chosen = [m for m in MODULES if m in only or set(load(m).FIGURES) & set(only)]
    unknown = set(only) - set(MODULES) - {f for m in MODULES for f in load(m).FIGURES}
    if unknown:
        raise SystemExit(f"openpendant bench: unknown benchmark or figure: {', '.join(unknown)}")
    return chosen


def table(figures: list[Figure]) -> str:
    rows = [("figure", "value", "unit", "target", "ok")]
    for f in figures:
        ok = "" if f.meets_target is None else ("yes" if f.meets_target else "NO")
        rows.append((f.name, f"{f.value:.4g}", f.unit, f.target, ok))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def main(only: list[str] | None = None, json_path: Path | None = None) -> int:
    figures: list[Figure] = []
    for module in select(only):
        started = time.monotonic()
        print(f"running {module}…", file=sys.stderr, flush=True)
        before = cpu_times()
        measured = load(module).run()
        # Timing figures on a VM depend on what the host lets it run: say how much it took.
        steal = steal_percent(before, cpu_times())
        for figure in measured:
            figure.details["host_cpu_steal_percent"] = steal
        if only and module not in only:  # chosen for the figures named, not as a whole
            measured = [f for f in measured if f.name in only]
        figures.extend(measured)
        print(
            f"  {module} took {time.monotonic() - started:.1f} s (host CPU steal {steal} %)",
            file=sys.stderr,
        )
    print(table(figures))
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        document = {f.name: {k: v for k, v in asdict(f).items() if k != "name"} for f in figures}
        document["_meta"] = {
            "time": time.time(),
            "python": platform.python_version(),
            "machine": platform.machine(),
            "cpus": _cpus(),
        }
        json_path.write_text(json.dumps(document, indent=2))
        print(f"wrote {json_path}", file=sys.stderr)
    return 0


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0))
