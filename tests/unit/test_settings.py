"""Configuration: defaults < YAML < environment < flags, and discovery interface choice."""

from __future__ import annotations

import uuid
from pathlib import Path

import pytest
from pydantic import ValidationError

from openpendant.runtime.drivers.run import device_uuid as driver_uuid
from openpendant.runtime.kit.settings import (
    RuntimeSettings,
    load_settings,
    resolve_interfaces,
    settings_for_child,
    settings_from_env,
)
from openpendant.runtime.launcher.run import device_uuid as launcher_uuid


def test_precedence(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    config = tmp_path / "site.yaml"
    config.write_text(
        "port: 9001\nstate_rate_hz: 50\ndevices:\n"
        "  - {driver: sim-robot, name: p1, options: {model: panda}}\n"
    )
    monkeypatch.setenv("OPENPENDANT_STATE_RATE_HZ", "60")
    settings = load_settings(config, port=9100)
    assert settings.port == 9100  # flag beats file
    assert settings.state_rate_hz == 60  # environment beats file
    assert settings.devices[0].options == {"model": "panda"}  # file beats default


def test_unknown_keys_in_a_config_file_are_errors(tmp_path: Path) -> None:
    config = tmp_path / "site.yaml"
    config.write_text("prot: 9001\n")
    with pytest.raises(ValidationError, match="prot"):
        load_settings(config)


def test_missing_config_file_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="config file not found"):
        load_settings(tmp_path / "nope.yaml")


def test_discovery_stays_on_loopback_when_the_ui_is_local() -> None:
    assert resolve_interfaces("auto", "127.0.0.1") == ["127.0.0.1"]
    assert resolve_interfaces("auto", "localhost") == ["127.0.0.1"]
    assert resolve_interfaces("auto", "0.0.0.0") == "all"
    assert resolve_interfaces(["10.0.0.5"], "0.0.0.0") == ["10.0.0.5"]


def test_children_get_exactly_the_launchers_settings(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    parent = RuntimeSettings(port=1234, data_dir=tmp_path, sim=False)
    for key, value in settings_for_child(parent).items():
        monkeypatch.setenv(key, value)
    monkeypatch.setenv("OPENPENDANT_PORT", "4321")  # ignored: the handed-down settings win
    assert settings_from_env() == parent


def test_the_example_site_config_is_valid() -> None:
    example = Path(__file__).parents[2] / "deploy" / "openpendant.example.yaml"
    settings = load_settings(example)
    assert settings.port == 8080
    assert settings.devices[0].options == {"model": "ur5"}


def test_a_config_from_before_the_devices_list_still_loads_and_keeps_its_robots(
    tmp_path: Path,
) -> None:
    """`sim_robots:` (before drivers were plugins) is read as sim-robot entries, and each
    robot keeps the uuid it had, so robots added then are still recognised."""
    config = tmp_path / "site.yaml"
    config.write_text("sim_robots:\n  - {model: panda, name: arm-2}\n")
    settings = load_settings(config)
    assert [(d.driver, d.name, d.options) for d in settings.devices] == [
        ("sim-robot", "arm-2", {"model": "panda"})
    ]
    # The uuids the launcher and a standalone simulator gave before.
    before = uuid.uuid5(uuid.UUID("3d0f54a8-5b0e-4a8e-9c5e-0f8d4b6a2c11"), "inst/panda/arm-2")
    assert launcher_uuid("inst", settings.devices[0]) == str(before)
    alone = uuid.uuid5(uuid.UUID("6f1d9a52-3c39-4b61-9d0e-5c2a1f6b7e10"), "sim-robot/ur5/sim-ur5")
    assert driver_uuid("sim-robot", "sim-ur5", "ur5") == str(alone)
    both = tmp_path / "both.yaml"
    both.write_text("sim_robots: []\ndevices: []\n")
    with pytest.raises(ValidationError, match="not both"):
        load_settings(both)
