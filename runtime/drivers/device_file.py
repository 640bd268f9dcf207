"""One device from one file: `openpendant device FILE`, what a driver board runs at boot
(deploy/systemd/openpendant-driver@.service) and what `install-service --driver` writes.
The file names an installed driver, the device's name, where it serves and the driver's
options; the device is then served and advertised as `openpendant driver` would."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import yaml
from pydantic import Field, ValidationError

from openpendant.runtime.drivers.run import run_driver
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.bounded_yaml import load_yaml
from openpendant.runtime.kit.settings import DeviceSpec

MAX_FILE = 64 * 1024  # bytes: a device file is a few lines


class DeviceFile(DeviceSpec):
    host: str = Field(default="0.0.0.0", min_length=1, max_length=255)
    port: int = Field(default=0, ge=0, le=65535)
    uuid: str | None = Field(default=None, min_length=1, max_length=64)


def read_device_file(path: Path) -> DeviceFile:
    """The file's device; ValueError saying what is wrong with it."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    if len(raw) > MAX_FILE:
        raise ValueError(f"{path} is not a device file (over {MAX_FILE // 1024} KiB)")
    try:
        data = load_yaml(raw)
    except yaml.YAMLError as exc:
        raise ValueError(f"{path} is not valid YAML: {exc}") from None
    try:
        return DeviceFile.model_validate(data)
    except ValidationError as exc:
        raise ValueError(f"{path}: {describe_validation_errors(exc.errors())[0]}") from None


def driver_argv(device: DeviceFile) -> list[str]:
    argv = ["--name", device.name, "--host", device.host, "--port", str(device.port)]
    argv += ["--options-json", json.dumps(device.options)]
    return argv + (["--uuid", device.uuid] if device.uuid else [])


def run_device_file(path: Path) -> int:
    try:
        device = read_device_file(path)
    except ValueError as exc:
        print(f"openpendant device: {exc}", file=sys.stderr)
        return 2
    return run_driver(device.driver, driver_argv(device))
