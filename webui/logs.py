"""The runtime's recent log entries, for the System panel: the tail of each process's log
file (JSON lines, see runtime/kit/logs.py), filtered by level, newest first."""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import BaseModel

LEVELS = {"debug": 10, "info": 20, "warning": 30, "error": 40, "critical": 50}
TAIL_BYTES = 256 * 1024  # of each file: recent enough, and bounded however large it grew
MAX_ENTRIES = 500


def _tail(path: Path) -> list[str]:
    with path.open("rb") as file:
        size = file.seek(0, 2)
        file.seek(max(0, size - TAIL_BYTES))
        data = file.read()
    lines = data.decode("utf-8", errors="replace").splitlines()
    return lines[1:] if size > TAIL_BYTES else lines  # the first may be cut


class LogEntry(BaseModel):
    ts: float
    time: str
    level: str
    service: str
    message: str


def recent_entries(log_dir: Path, level: str = "warning", limit: int = 100) -> list[LogEntry]:
    """Entries at `level` or above from every log file, newest first, at most `limit`."""
    floor = LEVELS.get(level, LEVELS["warning"])
    found: list[LogEntry] = []
    for path in sorted(log_dir.glob("*.log")) if log_dir.is_dir() else []:
        for line in _tail(path):
            try:
                entry = json.loads(line)
            except ValueError:
                continue  # a process's plain output (a crash trace) is not an entry
            if not isinstance(entry, dict) or LEVELS.get(entry.get("level", ""), 0) < floor:
                continue
            ts = entry.get("ts")
            found.append(
                LogEntry(
                    ts=float(ts) if isinstance(ts, int | float) else 0.0,
                    time=str(entry.get("time", "")),
                    level=str(entry.get("level")),
                    service=str(entry.get("service", path.stem)),
                    message=str(entry.get("msg", ""))[:2000],
                )
            )
    found.sort(key=lambda e: e.ts)
    return found[::-1][: max(1, min(limit, MAX_ENTRIES))]
