"""A cell's data, backed up and restored: `openpendant backup` while the runtime runs,
`restore` refused while it does, then after a loss everything is back (a taught waypoint, a
saved program, a user, the paired robot with its secret) and the restored runtime moves the
robot with that program; a damaged database stops the next start, naming the file and the
restore command; a backup whose bytes were changed is refused."""

from __future__ import annotations

import io
import os
import shutil
import sqlite3
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import numpy as np

from openpendant.runtime.auth.setup import auth_path
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.jog import Cell
from openpendant.runtime.bench.harness.processes import Runtime, child_env, wait_for
from openpendant.runtime.kit.tls import CA_CERT, TLS_DIR
from tests.support.programs import teach

TARGET = [1.0, -1.2, 1.4, -1.5, -1.57, 0.5]


def openpendant(home: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", *args],
        env=child_env(home),
        capture_output=True,
        text=True,
        timeout=120,
    )


def backed_up(home: Path, data_dir: Path, archive: Path) -> None:
    made = openpendant(home, "backup", "--data-dir", str(data_dir), "--output", str(archive))
    assert made.returncode == 0, made.stderr


def users(data_dir: Path) -> list[str]:
    store = AuthStore(auth_path(data_dir))
    try:
        return [u.name for u in store.users()]
    finally:
        store.close()


def test_backup_then_restore_brings_everything_back_and_the_robot_moves(tmp_path: Path) -> None:
    home = tmp_path / "cell"
    # Over HTTPS: its certificate authority, which the tablets trust, comes back too.
    runtime = Runtime(home, extra=["--tls"])
    runtime.wait_ready()
    authority = (runtime.data_dir / TLS_DIR / CA_CERT).read_bytes()
    archive = tmp_path / "cell-backup.tar.gz"
    try:
        Cell(runtime)  # the robot added and paired
        teach(runtime, {"target": TARGET})
        saved = runtime.api(
            "PUT", "/programs/to_target", json={"python": "move_joint(waypoint('target'))\n"}
        )
        assert saved.status_code == 200, saved.text
        runtime.user("operator")
        (runtime.data_dir / "models").mkdir()
        (runtime.data_dir / "models" / "parts.onnx").write_bytes(b"a network")
        made = openpendant(
            home, "backup", "--data-dir", str(runtime.data_dir), "--output", str(archive)
        )
        assert made.returncode == 0, made.stderr
        assert archive.stat().st_mode & 0o777 == 0o600
        busy = openpendant(home, "restore", str(archive), "--data-dir", str(runtime.data_dir))
        assert busy.returncode == 2 and "stop it first" in busy.stderr
    finally:
        runtime.stop()

    # Lost: the databases and the pairing secrets (a disk replaced, a wrong command).
    for name in ("variables.sqlite", "auth.sqlite"):
        (runtime.data_dir / name).unlink()
    for secret in (runtime.data_dir / "device-secrets").iterdir():
        secret.unlink()
    shutil.rmtree(runtime.data_dir / TLS_DIR)
    restored = openpendant(home, "restore", str(archive), "--data-dir", str(runtime.data_dir))
    assert restored.returncode == 0, restored.stderr
    assert list(tmp_path.joinpath("cell").glob("openpendant.before-restore-*"))
    assert "operator-user" in users(runtime.data_dir)
    assert (runtime.data_dir / "models" / "parts.onnx").read_bytes() == b"a network"

    assert (runtime.data_dir / TLS_DIR / CA_CERT).read_bytes() == authority
    again = Runtime(home, extra=["--tls"])
    again.wait_ready()
    assert again.url.startswith("https://")
    assert (again.data_dir / TLS_DIR / CA_CERT).read_bytes() == authority
    try:
        assert again.api("GET", "/variables/target").json()["value"]["joints"] == TARGET
        assert [d["local_name"] for d in again.api("GET", "/devices").json()] == ["robot"]
        cell = Cell(again)  # already added: it connects with the restored secret
        cell.ready()
        ran = again.api("POST", "/programs/to_target/run", json={"leases": {"robot": cell.token}})
        assert ran.status_code == 202, ran.text
        wait_for(
            lambda: again.api("GET", "/programs/to_target/status").json()["state"] == "finished",
            60,
            what="the restored program's end",
        )
        assert np.abs(cell.robot.q() - np.array(TARGET)).max() < 1e-3
    finally:
        again.stop()

    # A damaged database: the next start refuses, naming it and the way back.
    database = runtime.data_dir / "variables.sqlite"
    with database.open("r+b") as raw:
        raw.seek(2 * 4096)
        raw.write(b"\xa5" * 4096)
    refused = openpendant(home, "run", "--port", "0", "--data-dir", str(runtime.data_dir))
    assert refused.returncode == 1
    assert str(database) in refused.stderr and "openpendant restore" in refused.stderr


def test_a_changed_backup_is_refused_and_nothing_is_replaced(tmp_path: Path) -> None:
    data_dir = tmp_path / "data"
    source = tmp_path / "source"
    source.mkdir()
    with sqlite3.connect(source / "variables.sqlite") as db:
        db.execute("CREATE TABLE t (v)")
        db.execute("INSERT INTO t VALUES (1)")
    archive = tmp_path / "b.tar.gz"
    backed_up(tmp_path, source, archive)
    with tarfile.open(archive) as original:
        members = {m.name: original.extractfile(m).read() for m in original.getmembers()}  # type: ignore[union-attr]
    members["variables.sqlite"] = members["variables.sqlite"].replace(b"\x01", b"\x02", 1)
    changed = tmp_path / "changed.tar.gz"
    with tarfile.open(changed, "w:gz") as out:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            out.addfile(info, io.BytesIO(data))
    data_dir.mkdir()
    (data_dir / "variables.sqlite").write_bytes(b"")
    refused = openpendant(tmp_path, "restore", str(changed), "--data-dir", str(data_dir))
    assert refused.returncode == 2 and "checksum" in refused.stderr
    assert sorted(p.name for p in data_dir.iterdir()) == ["variables.sqlite"]
    assert not list(tmp_path.glob("data.before-restore-*"))


def test_a_data_directory_reached_through_a_link_is_restored_where_it_is(tmp_path: Path) -> None:
    """systemd's state directory (/var/lib/openpendant) is a link to a private one: restoring
    through the link replaced the link and left the data behind it live."""
    private = tmp_path / "private" / "openpendant"
    private.mkdir(parents=True)
    with sqlite3.connect(private / "variables.sqlite") as db:
        db.execute("CREATE TABLE t (v)")
    link = tmp_path / "openpendant"
    link.symlink_to(private)
    archive = tmp_path / "b.tar.gz"
    backed_up(tmp_path, link, archive)
    done = openpendant(tmp_path, "restore", str(archive), "--data-dir", str(link))
    assert done.returncode == 0, done.stderr
    assert link.is_symlink() and link.resolve() == private.resolve()
    assert (private / "variables.sqlite").is_file()
    assert list((tmp_path / "private").glob("openpendant.before-restore-*"))


def test_a_scheduled_backup_is_dated_and_old_ones_go(tmp_path: Path) -> None:
    """What the backup timer runs: an archive into backups.folder, and the archives older
    than backups.keep_days removed; nothing else in the folder is touched."""
    data = tmp_path / "data"
    data.mkdir()
    with sqlite3.connect(data / "variables.sqlite") as db:
        db.execute("CREATE TABLE t (v)")
    folder = tmp_path / "backups"
    folder.mkdir()
    old, recent, other = (
        folder / "openpendant-20260101-000000.tar.gz",
        folder / "openpendant-20261126-000000.tar.gz",
        folder / "notes.txt",
    )
    for path in (old, recent, other):
        path.write_bytes(b"x")
    three_days_ago = time.time() - 3 * 86400
    for path in (old, other):
        os.utime(path, (three_days_ago, three_days_ago))
    config = tmp_path / "openpendant.yaml"
    config.write_text(f"backups: {{folder: {folder}, keep_days: 1}}\n")
    done = openpendant(
        tmp_path, "backup", "--scheduled", "--config", str(config), "--data-dir", str(data)
    )
    assert done.returncode == 0, done.stderr
    left = sorted(p.name for p in folder.iterdir())
    made = [n for n in left if n not in (recent.name, other.name)]
    assert len(made) == 1 and made[0].startswith("openpendant-") and old.name not in left
    assert recent.name in left and other.name in left
    with tarfile.open(folder / made[0]) as archive:
        assert "manifest.json" in archive.getnames()
    unset = openpendant(tmp_path, "backup", "--scheduled", "--data-dir", str(data))
    assert unset.returncode == 2 and "backups: {folder: DIR}" in unset.stderr
