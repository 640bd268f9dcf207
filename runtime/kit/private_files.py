"""What the runtime and its drivers keep is theirs alone: the variables (programs, waypoints,
calibrations), the logs (who did what), the user and audit databases, leases and device
secrets. A process calls `keep_private` once, before it writes: every file it makes from
then on is 0600 and every folder 0700, and what its folders already hold is made so (a data
directory from before, or copied in with other modes)."""

from __future__ import annotations

import logging
import os
import stat
from pathlib import Path
from typing import TextIO

log = logging.getLogger(__name__)

OTHERS = 0o077  # the group's and everyone else's bits


def keep_private(data_dir: Path, logs: Path | None = None) -> None:
    """The data directory is the runtime's whole; a logs folder elsewhere (`log_dir`, which
    may be shared, /var/log) has only its `*.log` files made private."""
    os.umask(OTHERS)
    data_dir.mkdir(parents=True, exist_ok=True)
    paths = [data_dir, *data_dir.rglob("*")]
    if logs is not None and not logs.resolve().is_relative_to(data_dir.resolve()):
        logs.mkdir(parents=True, exist_ok=True)
        paths += logs.glob("*.log")
    for path in paths:
        _private(path)


def _private(path: Path) -> None:
    try:
        found = path.lstat()
    except FileNotFoundError:
        return  # removed meanwhile (a log rotated)
    mode = stat.S_IMODE(found.st_mode)
    if stat.S_ISLNK(found.st_mode) or not mode & OTHERS:
        return
    try:
        path.chmod(mode & ~OTHERS)
    except PermissionError:
        log.warning("cannot make %s private to its owner: it is not ours", path)


def shown_secret(secret: str, kept: Path, stream: TextIO) -> str:
    """A secret as a start-up message on `stream` shows it: itself on a terminal; where it is
    kept (this user's only) when the output goes elsewhere: systemd's journal is read by more
    people than the cell's administrator."""
    if stream.isatty():
        return secret
    if not kept.is_file() or kept.read_text().strip() != secret:
        kept.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        kept.touch(mode=0o600)
        kept.chmod(0o600)
        kept.write_text(secret + "\n")
    return f"kept in {kept}"
