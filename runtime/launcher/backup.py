"""What a cell keeps, kept safe: `openpendant backup` copies every database online (SQLite's
backup API: a consistent copy while the runtime runs and writes), the devices' pairing
secrets, the installation's id, the site config and the installed plugins' names into one
archive with a manifest of SHA-256 sums; `openpendant restore` refuses while a runtime uses
the data directory, checks every sum and every database, and keeps the directory it
replaces beside the new one. At start, every database must pass `PRAGMA quick_check`: a
damaged one stops the start with its name and the command that restores it, and is never
made anew in silence."""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import io
import json
import os
import shutil
import sqlite3
import tarfile
import tempfile
import time
from collections.abc import Iterator
from importlib.metadata import entry_points
from pathlib import Path

from openpendant.runtime import __version__
from openpendant.runtime.kit.schema import KNOWN, SchemaTooNew, refuse_newer
from openpendant.runtime.kit.tls import TLS_DIR

DATABASES = tuple(KNOWN)  # every database a runtime keeps
KEPT = ("runtime-id",)  # files kept as they are (the installation's id: its devices' uuids)
SECRETS = "device-secrets"
# Kept whole: pairing secrets, installed detector networks, the HTTPS certificate authority
# (tablets trust it: a restored cell keeps that trust).
FOLDERS = (SECRETS, "models", TLS_DIR)
LOCK = "runtime.lock"
MANIFEST = "manifest.json"
FORMAT = 1


class BackupError(Exception):
    """What is wrong, said for the person at the keyboard."""


@contextlib.contextmanager
def data_lock(data_dir: Path) -> Iterator[None]:
    """Held while a runtime uses the data directory (by the launcher, for its whole run)."""
    data_dir.mkdir(parents=True, exist_ok=True)
    fd = os.open(data_dir / LOCK, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise BackupError(f"a runtime is using {data_dir}: stop it first") from None
        yield
    finally:
        os.close(fd)


def runtime_running(data_dir: Path) -> bool:
    """Whether a runtime holds the data directory now (nothing is made or changed)."""
    try:
        fd = os.open(data_dir / LOCK, os.O_RDWR)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # closing releases a lock it took
    return False


def damaged(database: Path) -> str | None:
    """Why a database is not whole (its quick check's first complaint), or None."""
    try:
        with contextlib.closing(sqlite3.connect(f"{database.as_uri()}?mode=ro", uri=True)) as db:
            found = db.execute("PRAGMA quick_check").fetchone()
    except sqlite3.DatabaseError as exc:
        return str(exc)
    return None if found and found[0] == "ok" else str(found[0] if found else "no answer")


def check_databases(data_dir: Path) -> None:
    """Every database whole, and none written by a newer release."""
    for name in DATABASES:
        path = data_dir / name
        if not path.exists():
            continue
        if (why := damaged(path)) is not None:
            raise BackupError(
                f"{path} is damaged ({why}); nothing was started. Restore the last backup: "
                f"openpendant restore FILE --data-dir {data_dir}"
            )
        with contextlib.closing(sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True)) as db:
            try:
                refuse_newer(db, path, KNOWN[name])
            except SchemaTooNew as exc:
                raise BackupError(f"{exc}; nothing was started") from None


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _plugins() -> list[str]:
    found = {
        f"{ep.dist.name} {ep.dist.version}" if ep.dist else ep.value
        for ep in entry_points(group="openpendant.plugins")
    }
    return sorted(found)


def backup(data_dir: Path, output: Path, config: Path | None = None) -> Path:
    """One archive of everything a cell keeps (written 0600, never over another file)."""
    data_dir = data_dir.resolve()  # systemd's state directory is a link to a private one
    if not (data_dir / DATABASES[0]).exists():
        raise BackupError(f"{data_dir} holds no runtime's data")
    members: dict[str, bytes] = {}
    with tempfile.TemporaryDirectory() as scratch:
        for name in DATABASES:
            source = data_dir / name
            if not source.exists():
                continue
            copy = Path(scratch) / name
            with (
                contextlib.closing(sqlite3.connect(f"{source.as_uri()}?mode=ro", uri=True)) as db,
                contextlib.closing(sqlite3.connect(copy)) as target,
            ):
                db.backup(target)
            members[name] = copy.read_bytes()
    for name in KEPT:
        if (data_dir / name).is_file():
            members[name] = (data_dir / name).read_bytes()
    for folder in FOLDERS:
        for path in sorted((data_dir / folder).rglob("*")):
            if path.is_file() and not path.is_symlink():
                members[path.relative_to(data_dir).as_posix()] = path.read_bytes()
    if config is not None:
        members["config/openpendant.yaml"] = config.read_bytes()
    manifest = {
        "format": FORMAT,
        "version": __version__,
        "made": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "plugins": _plugins(),
        "files": {name: _sha256(data) for name, data in members.items()},
    }
    members[MANIFEST] = json.dumps(manifest, indent=2).encode()
    fd = os.open(output, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as raw, tarfile.open(fileobj=raw, mode="w:gz") as archive:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size, info.mode, info.mtime = len(data), 0o600, int(time.time())
            archive.addfile(info, io.BytesIO(data))
    return output


SCHEDULED = "openpendant-*.tar.gz"


def scheduled_backup(data_dir: Path, folder: Path, keep_days: int, config: Path | None) -> Path:
    """A dated archive in `folder`, and those there older than `keep_days` removed (only
    archives this names; nothing else in the folder is touched)."""
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    made = backup(data_dir, folder / f"openpendant-{time.strftime('%Y%m%d-%H%M%S')}.tar.gz", config)
    oldest = time.time() - keep_days * 86400
    for archive in folder.glob(SCHEDULED):
        if archive != made and archive.is_file() and archive.stat().st_mtime < oldest:
            archive.unlink()
    return made


def read_archive(archive_path: Path) -> dict[str, bytes]:
    """The archive's files, each checked against its manifest."""
    try:
        with tarfile.open(archive_path, mode="r:gz") as archive:
            members = {}
            for info in archive.getmembers():
                if not info.isfile() or info.name.startswith("/") or ".." in info.name.split("/"):
                    raise BackupError(f"{archive_path}: {info.name!r} is no backup's file")
                extracted = archive.extractfile(info)
                assert extracted is not None
                members[info.name] = extracted.read()
    except (OSError, tarfile.TarError) as exc:
        raise BackupError(f"{archive_path} is not a backup: {exc}") from None
    try:
        manifest = json.loads(members.pop(MANIFEST))
        sums = dict(manifest["files"])
    except (KeyError, ValueError, TypeError):
        raise BackupError(f"{archive_path} has no readable manifest") from None
    if manifest.get("format") != FORMAT:
        raise BackupError(f"{archive_path} is of another format ({manifest.get('format')!r})")
    if set(sums) != set(members):
        raise BackupError(f"{archive_path}: its files are not those its manifest lists")
    for name, data in members.items():
        if _sha256(data) != sums[name]:
            raise BackupError(f"{archive_path}: {name} is not what was backed up (checksum)")
    return members


def restore(archive_path: Path, data_dir: Path) -> Path:
    """The backup in place of `data_dir`; returns where the directory it replaced is kept."""
    members = read_archive(archive_path)
    data_dir = data_dir.resolve()  # renamed where it is, not a link to it
    owner = data_dir.stat() if data_dir.exists() else None
    with data_lock(data_dir):
        staging = Path(tempfile.mkdtemp(prefix=".restoring-", dir=data_dir.parent))
        try:
            _stage(staging, members, archive_path, owner)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        stamp = time.strftime("%Y%m%d-%H%M%S")
        kept = data_dir.with_name(f"{data_dir.name}.before-restore-{stamp}")
        logs = data_dir / "logs"
        if logs.is_dir():
            logs.rename(staging / "logs")  # the logs stay with the installation
        data_dir.rename(kept)
        staging.rename(data_dir)
    return kept


def _stage(
    staging: Path, members: dict[str, bytes], archive_path: Path, owner: os.stat_result | None
) -> None:
    """The archive's files written into `staging`, checked, and owned as the data was."""
    os.chmod(staging, 0o700)
    for name, data in members.items():
        if name.startswith("config/"):
            continue  # the site's config is the administrator's to put back
        target = staging / name
        target.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
    try:
        check_databases(staging)
    except BackupError as exc:
        raise BackupError(f"{archive_path} holds a damaged database: {exc}") from None
    if owner is not None and os.geteuid() == 0:
        # Restored by root for a runtime that runs as its own user: the files are its.
        for path in (staging, *staging.rglob("*")):
            os.chown(path, owner.st_uid, owner.st_gid)
