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

log = logging.getLogger(__name__)

OTHERS = 0o077  # the group's and everyone else's bits


def keep_private(*folders: Path) -> None:
    os.umask(OTHERS)
    for folder in folders:
        folder.mkdir(parents=True, exist_ok=True)
        for path in (folder, *folder.rglob("*")):
            try:
                found = path.lstat()
            except FileNotFoundError:
                continue  # removed meanwhile (a log rotated)
            mode = stat.S_IMODE(found.st_mode)
            if stat.S_ISLNK(found.st_mode) or not mode & OTHERS:
                continue
            try:
                path.chmod(mode & ~OTHERS)
            except PermissionError:
                log.warning("cannot make %s private to its owner: %s is not ours", path, path)
