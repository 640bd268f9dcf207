"""What the runtime keeps is its owner's alone: folders it is given are made 0700 and their
files 0600, whatever they were, and what the process makes afterwards is so as well."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from openpendant.runtime.kit.private_files import keep_private


@pytest.fixture
def restored_umask() -> Iterator[None]:
    before = os.umask(0o022)
    os.umask(before)
    yield
    os.umask(before)


def mode(path: Path) -> int:
    return stat.S_IMODE(path.lstat().st_mode)


def test_a_data_directory_from_before_is_made_private_and_stays_so(
    tmp_path: Path, restored_umask: None
) -> None:
    data = tmp_path / "data"
    (data / "device-secrets").mkdir(parents=True, mode=0o755)
    (data / "device-secrets").chmod(0o755)
    (data / "variables.sqlite").write_text("x")
    (data / "variables.sqlite").chmod(0o644)
    (data / "device-secrets" / "robot").write_text("secret")
    (data / "device-secrets" / "robot").chmod(0o664)
    (data / "tool.sh").write_text("#!/bin/sh\n")
    (data / "tool.sh").chmod(0o755)
    outside = tmp_path / "outside.txt"
    outside.write_text("not ours to change")
    outside.chmod(0o644)
    (data / "link").symlink_to(outside)
    logs = tmp_path / "logs"

    keep_private(data, logs)

    assert mode(data) == 0o700 and mode(data / "device-secrets") == 0o700
    assert mode(data / "variables.sqlite") == 0o600
    assert mode(data / "device-secrets" / "robot") == 0o600
    assert mode(data / "tool.sh") == 0o700
    assert mode(outside) == 0o644  # a link's target is left alone
    assert logs.is_dir() and mode(logs) == 0o700
    (logs / "runtime.log").write_text("made afterwards")
    (data / "new").mkdir()
    assert mode(logs / "runtime.log") == 0o600 and mode(data / "new") == 0o700


def test_a_logs_folder_elsewhere_keeps_what_is_not_ours(
    tmp_path: Path, restored_umask: None
) -> None:
    """`log_dir` may be a shared folder (/var/log): only the runtime's own logs in it change."""
    shared = tmp_path / "var-log"
    shared.mkdir(mode=0o755)
    shared.chmod(0o755)
    (shared / "syslog").write_text("someone else's")
    (shared / "syslog").chmod(0o644)
    (shared / "webui.log").write_text("ours")
    (shared / "webui.log").chmod(0o644)
    keep_private(tmp_path / "data", shared)
    assert mode(shared) == 0o755 and mode(shared / "syslog") == 0o644
    assert mode(shared / "webui.log") == 0o600
