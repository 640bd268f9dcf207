"""An upgrade keeps the data: every data directory an earlier release left
(tests/fixtures/data-<version>/, written by tests/fixtures/make_release_data.py with that
release's code) opens with this code, passes the start's checks and keeps what it held; a
database written by a newer release is refused, at start and by its store, and changes
nothing."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import pytest

from openpendant.runtime.auth.audit import AUDIT_FILE, AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.kit.schema import KNOWN, SchemaTooNew, stored_version
from openpendant.runtime.launcher.backup import BackupError, check_databases
from openpendant.runtime.variable_storage.store import VariableStore
from tests.fixtures.make_release_data import PASSWORD, PROGRAM, WAYPOINT

RELEASES = sorted((Path(__file__).resolve().parents[1] / "fixtures").glob("data-*"))


def test_there_is_a_release_to_upgrade_from() -> None:
    assert RELEASES, "tests/fixtures/data-<version>/ is missing"


@pytest.mark.parametrize("release", RELEASES, ids=[r.name for r in RELEASES])
def test_a_data_directory_of_an_earlier_release_opens_with_everything_in_it(
    release: Path, tmp_path: Path
) -> None:
    data = tmp_path / "data"
    shutil.copytree(release, data)
    check_databases(data)
    variables = VariableStore(data / "variables.sqlite")
    try:
        assert variables.get("home_wp").value == WAYPOINT
        assert variables.get("program.pick").value["python"] == PROGRAM["python"]
    finally:
        variables.close()
    auth = AuthStore(auth_path(data))
    try:
        assert auth.verify("ada", PASSWORD) is Role.admin
    finally:
        auth.close()
    audit = AuditLog(data / AUDIT_FILE)
    try:
        assert [e.action for e in audit.entries()] == ["POST /api/devices"]
    finally:
        audit.close()
    for name, version in KNOWN.items():
        with sqlite3.connect(data / name) as db:
            assert stored_version(db) == version  # opened: at this release's version


def test_a_database_written_by_a_newer_release_is_refused_and_left_alone(tmp_path: Path) -> None:
    data = tmp_path / "data"
    shutil.copytree(RELEASES[-1], data)
    path = data / "variables.sqlite"
    with sqlite3.connect(path) as db:
        db.execute(f"PRAGMA user_version = {KNOWN['variables.sqlite'] + 1}")
    before = path.read_bytes()
    with pytest.raises(BackupError, match="newer OpenPendant"):
        check_databases(data)
    with pytest.raises(SchemaTooNew, match=r"variables\.sqlite"):
        VariableStore(path)
    assert path.read_bytes() == before
