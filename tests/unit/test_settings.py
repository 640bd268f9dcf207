"""Configuration: defaults < YAML < environment < flags, and discovery interface choice."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from runtime.kit.settings import (
    RuntimeSettings,
    load_settings,
    resolve_interfaces,
    settings_for_child,
    settings_from_env,
)


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
