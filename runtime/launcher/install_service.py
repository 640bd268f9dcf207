"""`openpendant install-service`: the runtime, and devices each served by a unit of their own,
as systemd services that start at boot and come back after a crash or a hang
(deploy/systemd/). Writes the units (the openpendant command's path filled in), the cell's
config and one file per device if they are not there yet (never over an edited one), then
enables them: started at once on this computer, or only linked below `--root` (an image
being prepared, a test)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

from openpendant.plugins.registry import registry

RUNTIME_UNIT = "openpendant.service"
BACKUP_UNITS = ("openpendant-backup.service", "openpendant-backup.timer")
DRIVER_UNIT = "openpendant-driver@.service"
COMMAND = "@OPENPENDANT@"
SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}\Z")
CELL_CONFIG = """\
# The cell's runtime (written by openpendant install-service; edit, then
# systemctl restart openpendant). Every setting: docs/user/configuration.md.
host: 0.0.0.0            # serve the UI to the tablets on the LAN
port: 8080
sim: false               # no simulated devices on a real cell
devices: []              # drivers the runtime starts itself; or one unit each (--driver)
backups:                 # openpendant-backup.timer: once a day, kept this many days
  folder: /var/lib/openpendant-backups
  keep_days: 14
"""


@dataclass(frozen=True)
class Device:
    driver: str
    name: str

    @property
    def unit(self) -> str:
        return DRIVER_UNIT.replace("@.", f"@{self.name}.")


def parse_device(text: str) -> Device:
    """`DRIVER:NAME` of an installed driver; ValueError saying what is wrong."""
    driver, _, name = text.partition(":")
    if driver not in registry().drivers:
        known = ", ".join(sorted(registry().drivers))
        raise ValueError(f"no driver {driver!r} is installed (installed: {known})")
    if not SAFE_NAME.match(name):
        raise ValueError(
            f"give DRIVER:NAME, NAME of letters, digits, '.', '_' or '-' (not {text!r})"
        )
    return Device(driver, name)


def device_file(device: Device) -> str:
    """A device's file, its driver's options listed (as comments) to fill in."""
    spec = registry().drivers[device.driver]
    lines = [
        f"# {device.name}: {spec.description}",
        "# Served by openpendant-driver@NAME.service; edit, then restart that unit. Its",
        f"# options: openpendant driver {device.driver} --help",
        f"driver: {device.driver}",
        f"name: {device.name}",
        "host: 0.0.0.0          # every interface: the runtime finds it by DNS-SD",
        "port: 0                # a free port, advertised",
        "options: {}",
    ]
    return "\n".join(lines) + "\n"


def command_path() -> Path:
    """The openpendant command of this installation (beside its Python)."""
    beside = Path(sys.executable).parent / "openpendant"
    found = beside if beside.is_file() else shutil.which("openpendant")
    if found is None:
        raise FileNotFoundError("the openpendant command is not installed beside this Python")
    return Path(found).absolute()


def unit_text(name: str, command: Path) -> str:
    template = files("openpendant.deploy").joinpath("systemd", name).read_text()
    return template.replace(COMMAND, str(command))


def write_new(path: Path, text: str, written: list[str]) -> None:
    """Writes `text` unless the file is there (an edited config is never replaced)."""
    if path.exists():
        written.append(f"kept     {path}")
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    written.append(f"wrote    {path}")


def install_service(root: Path, drivers: list[str], runtime: bool, enable: bool) -> int:
    try:
        devices = [parse_device(text) for text in drivers]
        command = command_path()
    except (ValueError, FileNotFoundError) as exc:
        print(f"openpendant install-service: {exc}", file=sys.stderr)
        return 2
    if not runtime and not devices:
        print("openpendant install-service: nothing to install", file=sys.stderr)
        return 2
    units_dir = root / "etc" / "systemd" / "system"
    config_dir = root / "etc" / "openpendant"
    units_dir.mkdir(parents=True, exist_ok=True)
    written: list[str] = []
    units = []
    if runtime:
        (units_dir / RUNTIME_UNIT).write_text(unit_text(RUNTIME_UNIT, command))
        written.append(f"wrote    {units_dir / RUNTIME_UNIT}")
        write_new(config_dir / "openpendant.yaml", CELL_CONFIG, written)
        for name in BACKUP_UNITS:
            (units_dir / name).write_text(unit_text(name, command))
            written.append(f"wrote    {units_dir / name}")
        units += [RUNTIME_UNIT, BACKUP_UNITS[1]]
    if devices:
        (units_dir / DRIVER_UNIT).write_text(unit_text(DRIVER_UNIT, command))
        written.append(f"wrote    {units_dir / DRIVER_UNIT}")
    for device in devices:
        write_new(config_dir / "devices" / f"{device.name}.yaml", device_file(device), written)
        units.append(device.unit)
    print("\n".join(written))
    if not enable:
        return 0
    return _enable(root, units)


def _enable(root: Path, units: list[str]) -> int:
    here = root.resolve() == Path("/")
    systemctl = ["systemctl"] if here else ["systemctl", f"--root={root}"]
    steps = [[*systemctl, "daemon-reload"]] if here else []
    steps.append([*systemctl, "enable", *(["--now"] if here else []), *units])
    for step in steps:
        done = subprocess.run(step, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            print(
                f"openpendant install-service: {' '.join(step)} failed: {done.stderr.strip()}",
                file=sys.stderr,
            )
            return 1
    print(("started and enabled: " if here else "enabled: ") + ", ".join(units))
    return 0
