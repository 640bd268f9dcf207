"""Niceness for processes that start sessions of their own.

Linux schedules each session as a group (autogroups, `sched_autogroup_enabled`): a process's
nice value weighs only against the other processes of its session, and the groups share the
cores evenly. Playwright starts Chromium in a session of its own, so a browser started at
nice 19 still took a whole core from the real-time tests beside it, as if it were not niced
at all (docs/testing.md). Giving its group this process's niceness puts it back behind them."""

from __future__ import annotations

import os
from pathlib import Path


def _stat(pid: int) -> tuple[int, int] | None:
    """(parent pid, session id), or None once the process is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return int(fields[1]), int(fields[3])


def nice_new_sessions(root: int | None = None) -> list[int]:
    """Every session begun by a descendant of `root` (this process by default) gets this
    process's niceness as its group's. Returns the session leaders changed (none where this
    process is not niced or autogroups are off)."""
    niceness = os.nice(0)
    enabled = Path("/proc/sys/kernel/sched_autogroup_enabled")
    if niceness <= 0 or not enabled.exists() or enabled.read_text().strip() != "1":
        return []
    root = os.getpid() if root is None else root
    pids = [int(name) for name in os.listdir("/proc") if name.isdigit()]
    stats = {pid: found for pid in pids if (found := _stat(pid)) is not None}
    children: dict[int, list[int]] = {}
    for pid, (parent, _) in stats.items():
        children.setdefault(parent, []).append(pid)
    own_session = os.getsid(0)
    changed = []
    below = list(children.get(root, []))
    while below:
        pid = below.pop()
        below.extend(children.get(pid, []))
        session = stats[pid][1]
        if session == pid and session != own_session:
            try:
                Path(f"/proc/{pid}/autogroup").write_text(str(niceness))
            except OSError:
                continue  # gone meanwhile
            changed.append(pid)
    return changed
