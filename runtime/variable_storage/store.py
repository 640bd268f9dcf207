"""SQLite persistence of variables and their history. A write returns only after its
transaction is durably committed (WAL + synchronous=FULL), so an acknowledged write survives
a crash or a kill -9 of the process.

A write may name its writer (a program's run: `program:<name>`) and that writer's budget:
every version in the history remembers who wrote it and how many bytes it holds, so the
bytes a writer's versions occupy are known exactly, evictions included, and a write that
would take them past the budget is refused in the same transaction that would make it."""

from __future__ import annotations

import json
import re
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from openpendant.runtime.interfaces.variables import NAME_PATTERN, Variable
from openpendant.runtime.kit import deadline
from openpendant.runtime.kit.errors import Conflict, InvalidValue, NotFound
from openpendant.runtime.kit.schema import VARIABLES, mark_version, refuse_newer
from openpendant.runtime.variable_storage.types import validate_value

TAG_PATTERN = re.compile(r"^[A-Za-z0-9_.:\-]{1,64}\Z")
WRITER_PATTERN = re.compile(r"^[A-Za-z0-9_.:\-]{1,128}\Z")
SCHEMA_VERSION = VARIABLES
# What a version costs besides its texts: its numbers, SQLite's record and index entries and
# the pages' slack (measured: 60-100 bytes). Charged so that a writer of many tiny values is
# bounded too.
VERSION_OVERHEAD = 100

SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS variables (
    name TEXT PRIMARY KEY,
    type TEXT NOT NULL,
    value TEXT NOT NULL,
    tags TEXT NOT NULL,
    doc TEXT NOT NULL,
    created REAL NOT NULL,
    updated REAL NOT NULL,
    version INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS history (
    name TEXT NOT NULL,
    version INTEGER NOT NULL,
    type TEXT NOT NULL,
    value TEXT,
    tags TEXT NOT NULL,
    doc TEXT NOT NULL,
    updated REAL NOT NULL,
    deleted INTEGER NOT NULL DEFAULT 0,
    writer TEXT,
    bytes INTEGER NOT NULL DEFAULT 0,
    PRIMARY KEY (name, version)
);
"""
# Schema 1 had no writer or size per version; its versions count for no writer.
MIGRATIONS = (
    "ALTER TABLE history ADD COLUMN writer TEXT",
    "ALTER TABLE history ADD COLUMN bytes INTEGER NOT NULL DEFAULT 0",
)
INDEXES = (
    "CREATE INDEX IF NOT EXISTS history_writer ON history (writer, bytes) WHERE writer IS NOT NULL"
)


class HistoryEntry(BaseModel):
    version: int
    type: str
    value: Any
    tags: list[str]
    doc: str
    updated: float
    deleted: bool


class Usage(BaseModel):
    """What one writer's versions occupy in the history (its current values among them)."""

    writer: str
    versions: int
    bytes: int


def check_name(name: str) -> None:
    if not NAME_PATTERN.match(name):
        raise InvalidValue(
            f"invalid variable name {name!r}: start with a letter; letters, digits, "
            "'_', '.', '-' only; at most 128 characters",
            code="invalid_name",
        )


def check_tags(tags: list[str]) -> list[str]:
    for tag in tags:
        if not TAG_PATTERN.match(tag):
            raise InvalidValue(f"invalid tag {tag!r}", code="invalid_tag")
    return sorted(set(tags))


class VariableStore:
    def __init__(self, path: Path, history_depth: int = 20) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.history_depth = history_depth
        self._lock = threading.Lock()
        self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        refuse_newer(self._db, path, SCHEMA_VERSION)  # before anything is written
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.execute("PRAGMA foreign_keys=ON")
        with self._write():
            for statement in SCHEMA.strip().split(";"):
                if statement.strip():
                    self._db.execute(statement)
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(history)")}
            if "writer" not in columns:
                for statement in MIGRATIONS:
                    self._db.execute(statement)
            self._db.execute(INDEXES)
            self._db.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES ('schema_version', ?)",
                (str(SCHEMA_VERSION),),
            )
            mark_version(self._db, SCHEMA_VERSION)

    def close(self) -> None:
        with self._lock:
            self._db.close()

    @contextmanager
    def _write(self) -> Iterator[None]:
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield
                # The last moment to refuse: a request its gateway gave up on is not applied.
                deadline.check()
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")

    # Reads ----------------------------------------------------------------------------------

    def get(self, name: str) -> Variable:
        with self._lock:
            row = self._db.execute(
                "SELECT name, type, value, tags, doc, created, updated, version "
                "FROM variables WHERE name = ?",
                (name,),
            ).fetchone()
        if row is None:
            raise NotFound(f"no variable named {name!r}", code="variable_not_found")
        return _variable(row)

    def query(self, tag: str | None = None, type_name: str | None = None) -> list[Variable]:
        query = (
            "SELECT name, type, value, tags, doc, created, updated, version "
            "FROM variables WHERE 1=1"
        )
        params: list[Any] = []
        if tag is not None:
            query += " AND EXISTS (SELECT 1 FROM json_each(variables.tags) WHERE value = ?)"
            params.append(tag)
        if type_name is not None:
            query += " AND type = ?"
            params.append(type_name)
        with self._lock:
            rows = self._db.execute(query + " ORDER BY name", params).fetchall()
        return [_variable(r) for r in rows]

    def history(self, name: str) -> list[HistoryEntry]:
        with self._lock:
            rows = self._db.execute(
                "SELECT version, type, value, tags, doc, updated, deleted FROM history "
                "WHERE name = ? ORDER BY version DESC",
                (name,),
            ).fetchall()
        if not rows:
            raise NotFound(f"no history for {name!r}", code="variable_not_found")
        return [
            HistoryEntry(
                version=r[0],
                type=r[1],
                value=None if r[2] is None else json.loads(r[2]),
                tags=json.loads(r[3]),
                doc=r[4],
                updated=r[5],
                deleted=bool(r[6]),
            )
            for r in rows
        ]

    def usage(self, writer: str) -> Usage:
        with self._lock:
            return self._usage(writer)

    def _usage(self, writer: str) -> Usage:
        versions, size = self._db.execute(
            "SELECT COUNT(*), COALESCE(SUM(bytes), 0) FROM history WHERE writer = ?", (writer,)
        ).fetchone()
        return Usage(writer=writer, versions=versions, bytes=size)

    # Writes ---------------------------------------------------------------------------------

    def put(
        self,
        name: str,
        type_name: str,
        value: Any,
        *,
        tags: list[str] | None = None,
        doc: str | None = None,
        expected_version: int | None = None,
        writer: str | None = None,
        budget: int | None = None,
    ) -> Variable:
        """`budget`: refuse the write (storage_full) if the bytes `writer`'s versions would
        occupy afterwards, this one in and whatever it pushes out of the history out, exceed
        it."""
        check_name(name)
        normalised = validate_value(type_name, value)
        checked_tags = None if tags is None else check_tags(tags)
        if writer is not None and not WRITER_PATTERN.match(writer):
            raise InvalidValue(f"invalid writer {writer[:40]!r}", code="invalid_writer")
        if budget is not None and writer is None:
            raise InvalidValue("a budget is a writer's: name the writer", code="invalid_writer")
        with self._write():
            variable = self._put_locked(
                name, type_name, normalised, checked_tags, doc, expected_version, writer
            )
            if writer is not None and budget is not None:
                self._check_budget(writer, budget)
            return variable

    def put_many(self, items: list[dict[str, Any]]) -> list[Variable]:
        """All or nothing: every item is validated before any is written."""
        prepared = []
        errors = []
        for item in items:
            try:
                name = str(item.get("name"))
                check_name(name)
                prepared.append(
                    (
                        name,
                        str(item.get("type")),
                        validate_value(str(item.get("type")), item.get("value")),
                        check_tags(list(item.get("tags") or [])),
                        str(item.get("doc") or ""),
                    )
                )
            except InvalidValue as exc:
                errors.append(f"{item.get('name')!r}: {exc.message}")
        if errors:
            raise InvalidValue("nothing imported: " + "; ".join(errors), code="invalid_import")
        with self._write():
            return [self._put_locked(*p, expected_version=None, writer=None) for p in prepared]

    def delete(self, name: str, expected_version: int | None = None) -> Variable:
        with self._write():
            current = self._current(name)
            if current is None:
                raise NotFound(f"no variable named {name!r}", code="variable_not_found")
            self._check_version(current, expected_version)
            self._delete_locked(current)
            return current

    def rename(self, name: str, to: str) -> tuple[Variable, Variable]:
        """Move a variable to a new name in one transaction (the old name's history records
        the move as a deletion). Returns (old, new)."""
        check_name(to)
        with self._write():
            current = self._current(name)
            if current is None:
                raise NotFound(f"no variable named {name!r}", code="variable_not_found")
            if self._current(to) is not None:
                raise Conflict(f"a variable named {to!r} exists already", code="exists")
            moved = self._put_locked(
                to,
                current.type,
                current.value,
                current.tags,
                current.doc,
                expected_version=None,
                writer=None,
            )
            self._delete_locked(current)
            return current, moved

    def _delete_locked(self, current: Variable) -> None:
        self._db.execute("DELETE FROM variables WHERE name = ?", (current.name,))
        tags = json.dumps(current.tags)
        self._db.execute(
            "INSERT INTO history (name, version, type, value, tags, doc, updated, deleted, "
            "bytes) VALUES (?, ?, ?, NULL, ?, ?, ?, 1, ?)",
            (
                current.name,
                self._next_version(current.name),
                current.type,
                tags,
                current.doc,
                time.time(),
                version_bytes(current.name, "", tags, current.doc, ""),
            ),
        )
        self._prune(current.name)

    def _put_locked(
        self,
        name: str,
        type_name: str,
        value: Any,
        tags: list[str] | None,
        doc: str | None,
        expected_version: int | None,
        writer: str | None,
    ) -> Variable:
        current = self._current(name)
        self._check_version(current, expected_version)
        if current is not None and current.type != type_name:
            raise Conflict(
                f"{name!r} is a {current.type}; delete it before storing a {type_name}",
                code="type_mismatch",
            )
        now = time.time()
        version = self._next_version(name)
        variable = Variable(
            name=name,
            type=type_name,
            value=value,
            tags=tags if tags is not None else (current.tags if current else []),
            doc=doc if doc is not None else (current.doc if current else ""),
            created=current.created if current else now,
            updated=now,
            version=version,
        )
        encoded = json.dumps(value, allow_nan=False)
        tags_text = json.dumps(variable.tags)
        self._db.execute(
            "INSERT INTO variables (name, type, value, tags, doc, created, updated, version) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT(name) DO UPDATE SET "
            "type=excluded.type, value=excluded.value, tags=excluded.tags, doc=excluded.doc, "
            "updated=excluded.updated, version=excluded.version",
            (
                name,
                type_name,
                encoded,
                tags_text,
                variable.doc,
                variable.created,
                now,
                version,
            ),
        )
        self._db.execute(
            "INSERT INTO history (name, version, type, value, tags, doc, updated, deleted, "
            "writer, bytes) VALUES (?, ?, ?, ?, ?, ?, ?, 0, ?, ?)",
            (
                name,
                version,
                type_name,
                encoded,
                tags_text,
                variable.doc,
                now,
                writer,
                version_bytes(name, encoded, tags_text, variable.doc, writer or ""),
            ),
        )
        self._prune(name)
        return variable

    def _current(self, name: str) -> Variable | None:
        row = self._db.execute(
            "SELECT name, type, value, tags, doc, created, updated, version "
            "FROM variables WHERE name = ?",
            (name,),
        ).fetchone()
        return None if row is None else _variable(row)

    def _next_version(self, name: str) -> int:
        # Versions keep counting across a delete, so history never reuses a number.
        row = self._db.execute(
            "SELECT MAX(version) FROM history WHERE name = ?", (name,)
        ).fetchone()
        return int(row[0] or 0) + 1

    @staticmethod
    def _check_version(current: Variable | None, expected: int | None) -> None:
        if expected is None:
            return
        actual = current.version if current is not None else 0
        if actual != expected:
            raise Conflict(
                f"version is {actual}, not {expected}: someone else changed it",
                code="version_conflict",
                details={"version": actual},
            )

    def _check_budget(self, writer: str, budget: int) -> None:
        usage = self._usage(writer)
        if usage.bytes > budget:
            raise Conflict(
                f"{writer} would keep {usage.bytes} bytes in {usage.versions} versions "
                f"(the history's included); its budget is {budget}",
                code="storage_full",
                details={**usage.model_dump(), "budget": budget},
            )

    def _prune(self, name: str) -> None:
        self._db.execute(
            "DELETE FROM history WHERE name = ? AND version <= "
            "(SELECT MAX(version) FROM history WHERE name = ?) - ?",
            (name, name, self.history_depth),
        )

    def integrity_check(self) -> str:
        with self._lock:
            return str(self._db.execute("PRAGMA integrity_check").fetchone()[0])


def version_bytes(name: str, value: str, tags: str, doc: str, writer: str) -> int:
    """What one version holds: its texts as stored (the name and the writer twice, as they
    also key the history's indexes) and its row."""
    texts = (name, name, value, tags, doc, writer, writer)
    return sum(len(text.encode()) for text in texts) + VERSION_OVERHEAD


def _variable(row: tuple[Any, ...]) -> Variable:
    return Variable(
        name=row[0],
        type=row[1],
        value=json.loads(row[2]),
        tags=json.loads(row[3]),
        doc=row[4],
        created=row[5],
        updated=row[6],
        version=row[7],
    )
