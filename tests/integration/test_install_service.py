"""A cell installed as systemd services, as far as a container allows: `install-service`
writes the units (with this installation's command), the cell's config and a device file,
links them as `systemctl enable` does, never replaces an edited file; systemd's own
`systemd-analyze verify` passes every unit; and the device file runs as a driver board
runs it (`openpendant device FILE`), serving and advertising its device (on loopback here)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
import yaml

from openpendant.runtime.bench.harness.processes import Proc, SimRobotProc, child_env

pytestmark = pytest.mark.concurrent

COMMAND = Path(sys.executable).parent / "openpendant"


def openpendant(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(COMMAND), *args], capture_output=True, text=True, timeout=120, env=env
    )


def verify(unit: Path, as_name: str, scratch: Path) -> None:
    """systemd-analyze verify, which reads a template's instance from the file's name."""
    analyze = shutil.which("systemd-analyze")
    assert analyze is not None, "install Debian's systemd (.ci/run does)"
    scratch.mkdir(exist_ok=True)
    named = scratch / as_name
    shutil.copy(unit, named)
    done = subprocess.run([analyze, "verify", str(named)], capture_output=True, text=True)
    assert (done.returncode, done.stderr) == (0, ""), done.stderr


class DeviceProc(SimRobotProc):
    """`openpendant device FILE`, the one command of a driver board."""

    def __init__(self, home: Path, file: Path) -> None:
        argv = [sys.executable, "-m", "openpendant.runtime.cli", "device", str(file)]
        Proc.__init__(self, argv, child_env(home), home / "device.log")
        self.home = home
        self.url = ""
        self.uuid = ""


def test_install_verify_enable_and_run_a_cell_and_a_driver_board(tmp_path: Path) -> None:
    root = tmp_path / "root"
    done = openpendant("install-service", "--root", str(root), "--driver", "sim-robot:arm1")
    assert done.returncode == 0, done.stderr
    units = root / "etc" / "systemd" / "system"
    runtime_unit, driver_unit = units / "openpendant.service", units / "openpendant-driver@.service"
    for unit in (runtime_unit, driver_unit):
        text = unit.read_text()
        assert f"ExecStart={COMMAND} " in text and "@OPENPENDANT@" not in text
    verify(runtime_unit, "openpendant.service", tmp_path / "verify")
    verify(driver_unit, "openpendant-driver@arm1.service", tmp_path / "verify")
    for name in ("openpendant-backup.service", "openpendant-backup.timer"):
        assert "@OPENPENDANT@" not in (units / name).read_text()
        verify(units / name, name, tmp_path / "verify")
    timers = units / "timers.target.wants"
    assert (timers / "openpendant-backup.timer").readlink() == Path(
        "/etc/systemd/system/openpendant-backup.timer"
    )
    wants = units / "multi-user.target.wants"
    assert (wants / "openpendant.service").readlink() == Path(
        "/etc/systemd/system/openpendant.service"
    )
    assert (wants / "openpendant-driver@arm1.service").readlink() == Path(
        "/etc/systemd/system/openpendant-driver@.service"
    )
    config = yaml.safe_load((root / "etc" / "openpendant" / "openpendant.yaml").read_text())
    assert config["sim"] is False and config["host"] == "0.0.0.0"
    assert config["backups"] == {"folder": "/var/lib/openpendant-backups", "keep_days": 14}

    # The device file, edited as its comments say (on loopback: this test's network rule).
    device_file = root / "etc" / "openpendant" / "devices" / "arm1.yaml"
    device = yaml.safe_load(device_file.read_text())
    assert device == {
        "driver": "sim-robot",
        "name": "arm1",
        "host": "0.0.0.0",
        "port": 0,
        "options": {},
    }
    device_file.write_text(
        yaml.safe_dump({**device, "host": "127.0.0.1", "options": {"model": "ur3"}})
    )
    again = openpendant("install-service", "--root", str(root), "--driver", "sim-robot:arm1")
    assert again.returncode == 0 and f"kept     {device_file}" in again.stdout
    assert yaml.safe_load(device_file.read_text())["options"] == {"model": "ur3"}

    board = DeviceProc(tmp_path / "board", device_file)
    try:
        board.wait_ready()
        info = httpx.get(f"{board.url}/info", timeout=5).json()
        assert info["identity"]["name"] == "arm1" and info["identity"]["model"] == "ur3"
    finally:
        board.stop()


def test_bad_input_is_refused_with_its_reason_and_writes_nothing(tmp_path: Path) -> None:
    root = tmp_path / "root"
    for args, why in (
        (["--driver", "no-such-driver:x"], "no driver 'no-such-driver'"),
        (["--driver", "sim-robot:../etc"], "DRIVER:NAME"),
        (["--no-runtime"], "nothing to install"),
    ):
        done = openpendant("install-service", "--root", str(root), *args)
        assert done.returncode == 2 and why in done.stderr, done.stderr
    assert not root.exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text("driver: sim-robot\nname: arm1\nspeed: 3\n")
    refused = openpendant("device", str(bad), env=child_env(tmp_path))
    assert refused.returncode == 2 and "speed" in refused.stderr, refused.stderr
