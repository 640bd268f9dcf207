"""Which version of its tables each database holds (SQLite's `user_version`), so an upgrade
knows what to migrate and an older runtime never writes into tables a newer one made."""

from __future__ import annotations

import sqlite3
from pathlib import Path

# The version each database's tables are at in this release.
VARIABLES, AUTH, AUDIT = 2, 1, 1
KNOWN = {"variables.sqlite": VARIABLES, "auth.sqlite": AUTH, "audit.sqlite": AUDIT}


class SchemaTooNew(Exception):
    pass


def stored_version(db: sqlite3.Connection) -> int:
    return int(db.execute("PRAGMA user_version").fetchone()[0])


def refuse_newer(db: sqlite3.Connection, path: Path, known: int) -> int:
    """The version the database holds; SchemaTooNew if a newer release wrote it."""
    found = stored_version(db)
    if found > known:
        raise SchemaTooNew(
            f"{path} was written by a newer OpenPendant (its tables are at version {found}, "
            f"this one knows up to {known}): run that release, or restore a backup made by "
            "this one"
        )
    return found


def mark_version(db: sqlite3.Connection, version: int) -> None:
    db.execute(f"PRAGMA user_version = {int(version)}")
