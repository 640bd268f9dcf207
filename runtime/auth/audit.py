"""The audit log: who did what, from where, when — append-only (the database itself refuses
to change or delete a row)."""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from openpendant.runtime.auth.store import private
from openpendant.runtime.kit.schema import AUDIT, mark_version, refuse_newer

SCHEMA = """
CREATE TABLE IF NOT EXISTS audit (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    ts REAL NOT NULL,
    user TEXT NOT NULL,
    role TEXT NOT NULL,
    address TEXT NOT NULL,
    action TEXT NOT NULL,
    target TEXT NOT NULL,
    status INTEGER NOT NULL,
    detail TEXT NOT NULL
);
CREATE TRIGGER IF NOT EXISTS audit_no_update BEFORE UPDATE ON audit
BEGIN SELECT RAISE(ABORT, 'the audit log is append-only'); END;
CREATE TRIGGER IF NOT EXISTS audit_no_delete BEFORE DELETE ON audit
BEGIN SELECT RAISE(ABORT, 'the audit log is append-only'); END;
"""
MAX_DETAIL = 4096
AUDIT_FILE = "audit.sqlite"  # in the data directory


@dataclass(frozen=True)
class Entry:
    seq: int
    ts: float
    user: str
    role: str
    address: str
    action: str
    target: str
    status: int
    detail: dict[str, Any]


class AuditLog:
    def __init__(self, path: Path, clock: Callable[[], float] = time.time) -> None:
        self.clock = clock
        path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        refuse_newer(self._db, path, AUDIT)  # before anything is written
        self._db.execute("PRAGMA journal_mode = WAL")
        # Written on the gateway's loop after each change: no fsync per entry (WAL keeps
        # the file whole; a power cut may lose the last moment's entries).
        self._db.execute("PRAGMA synchronous = NORMAL")
        self._db.executescript(SCHEMA)
        mark_version(self._db, AUDIT)
        private(path)
        self._lock = threading.Lock()

    def close(self) -> None:
        self._db.close()

    def record(
        self,
        *,
        user: str,
        role: str,
        address: str,
        action: str,
        target: str = "",
        status: int = 200,
        detail: dict[str, Any] | None = None,
    ) -> None:
        text = json.dumps(detail or {}, default=str)[:MAX_DETAIL]
        with self._lock:
            self._db.execute(
                "INSERT INTO audit (ts, user, role, address, action, target, status, detail) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (self.clock(), user, role, address, action, target[:512], status, text),
            )

    def entries(self, *, before: int | None = None, limit: int = 100) -> list[Entry]:
        """Newest first; `before`: entries older than that sequence number (paging)."""
        query = "SELECT seq, ts, user, role, address, action, target, status, detail FROM audit"
        args: list[Any] = []
        if before is not None:
            query += " WHERE seq < ?"
            args.append(before)
        query += " ORDER BY seq DESC LIMIT ?"
        args.append(limit)
        with self._lock:
            rows = self._db.execute(query, args).fetchall()
        return [_entry(r) for r in rows]

    def export_lines(self) -> str:
        """Every entry, oldest first, one JSON object per line."""
        with self._lock:
            rows = self._db.execute(
                "SELECT seq, ts, user, role, address, action, target, status, detail FROM audit "
                "ORDER BY seq"
            ).fetchall()
        return "".join(json.dumps(asdict(_entry(r))) + "\n" for r in rows)


def _entry(row: Any) -> Entry:
    seq, ts, user, role, address, action, target, status, detail = row
    return Entry(seq, ts, user, role, address, action, target, status, _detail(detail))


def _detail(text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except ValueError:
        return {"text": text}
    return value if isinstance(value, dict) else {"value": value}
