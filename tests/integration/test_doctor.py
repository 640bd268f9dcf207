"""`openpendant doctor` on a computer with problems says each with what to do, and exits 1
while something must be fixed; on a healthy one it says ok. It changes nothing."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest

from openpendant.runtime.bench.harness.processes import child_env, free_port
from openpendant.runtime.variable_storage.store import VariableStore

pytestmark = pytest.mark.concurrent


def doctor(home: Path, data: Path, port: int) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "openpendant.runtime.cli", "doctor"]
        + ["--data-dir", str(data), "--port", str(port)],
        env=child_env(home),
        capture_output=True,
        text=True,
        timeout=60,
    )


def snapshot(folder: Path) -> dict[str, tuple[int, bytes]]:
    return {
        str(p): (p.stat().st_mode, p.read_bytes()) for p in sorted(folder.rglob("*")) if p.is_file()
    }


def test_each_problem_is_named_with_what_to_do_and_nothing_is_changed(tmp_path: Path) -> None:
    data = tmp_path / "data"
    store = VariableStore(data / "variables.sqlite")
    gone = free_port()  # nothing listens there
    record = {
        "uuid": "u-1",
        "local_name": "robot",
        "kind": "robot",
        "model": "ur5",
        "name": "arm",
        "url": f"http://127.0.0.1:{gone}",
    }
    store.put("devices.robot", "device", record)
    store.close()
    (data / "variables.sqlite").chmod(0o644)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        taken = busy.getsockname()[1]
        before = snapshot(data)
        found = doctor(tmp_path, data, taken)
    assert found.returncode == 1, found.stdout + found.stderr
    out = found.stdout
    assert f"fix   the UI port 127.0.0.1:{taken} cannot be used" in out
    assert "--port" in out
    assert "warn  readable by other users" in out and "chmod -R go-rwx" in out
    assert f"warn  device robot does not answer at 127.0.0.1:{gone}" in out
    assert "ok    discovery on lo" in out
    after = snapshot(data)  # (SQLite's readers may add a database's -shm and -wal files)
    assert {name: after[name] for name in before} == before

    # A damaged database: named, with the way back.
    with (data / "variables.sqlite").open("r+b") as raw:
        raw.seek(2 * 4096)
        raw.write(b"\xa5" * 4096)
    damaged = doctor(tmp_path, data, free_port())
    assert damaged.returncode == 1
    assert f"fix   {data / 'variables.sqlite'} is damaged" in damaged.stdout
    assert "openpendant restore" in damaged.stdout


def test_a_healthy_computer_is_ok(tmp_path: Path) -> None:
    data = tmp_path / "data"
    VariableStore(data / "variables.sqlite").close()
    for path in (data, *data.rglob("*")):
        path.chmod(0o700 if path.is_dir() else 0o600)
    found = doctor(tmp_path, data, free_port())
    assert found.returncode == 0, found.stdout
    assert "fix " not in found.stdout
    assert "ok    data directory" in found.stdout and "databases whole" in found.stdout
