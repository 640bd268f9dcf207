"""Runtime settings: defaults < YAML file < environment (OPENPENDANT_*) < command-line flags."""

from __future__ import annotations

import ipaddress
import json
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    YamlConfigSettingsSource,
)

SETTINGS_ENV = "OPENPENDANT_SETTINGS_JSON"


def default_data_dir() -> Path:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "openpendant"


class DiscoverySettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    # "auto": loopback only when the UI is bound to loopback, else every interface.
    interfaces: Literal["auto", "all"] | list[str] = "auto"
    # s a device's announcement lasts where its goodbye was lost (it lost power).
    ttl: int = Field(default=15, ge=2, le=4500)


class LinkSettings(BaseModel):
    """The device manager's one link per device (DESIGN.md §6: a stale link is a fault)."""

    model_config = ConfigDict(extra="forbid")

    # A link whose newest state is older than this is stale: its motion is halted and ends
    # failed. 20 periods of the 100 Hz state stream: a loaded 2-core host stalls a process
    # for tens of milliseconds now and then, and a stall is not a lost link.
    stale_after: float = Field(default=0.2, ge=0.02, le=5.0)
    # A driver halts the robot and ends the runtime's session after this long without a
    # message from it (the device manager sends a keepalive every quarter of it).
    driver_timeout: float = Field(default=0.3, ge=0.05, le=5.0)
    # A robot's speed override when its link comes up (added, back after a loss, the runtime
    # started again) and when it first comes into focus on a pendant: lowered to this if it
    # was higher, so nobody's first hold runs at full speed. Raising it needs control. 10 %,
    # as FANUC's override after a cold start: a one-second hold then moves any TCP at most
    # 25 mm (the manual cap's 250 mm/s scaled); at 25 % the UR5's J1 moved it 80 mm.
    first_speed_ratio: float = Field(default=0.10, gt=0.0, le=1.0)


class AuthSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    # A session ends after this long unused, and after the second figure in any case.
    session_idle_minutes: float = Field(default=60.0, ge=1, le=24 * 60)
    session_hours: float = Field(default=12.0, ge=0.1, le=24 * 30)


class MotionSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    # A move whose TCP leaves its planned path by more than this (m), or whose joints leave
    # their planned path by more than `joint_path_tolerance` (rad), is stopped as a
    # protective stop (`path_deviation`).
    path_tolerance: float = Field(default=0.005, gt=0, le=0.1)
    joint_path_tolerance: float = Field(default=0.02, gt=0, le=0.5)


class ProgramSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    # Runs at once: each robot takes one (its lease allows no more), and a few programs that
    # command no robot may run beside them. A worker may take 256 MiB and an hour of CPU.
    runs_without_robots: int = Field(default=3, ge=0, le=64)


class BackupSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    # Where `openpendant backup --scheduled` (the backup timer) writes, and how many days
    # its archives are kept there.
    folder: Path | None = None
    keep_days: int = Field(default=14, ge=1, le=3650)


class TlsSettings(BaseModel):
    """HTTPS for the UI's port and the jog socket (`run --tls`)."""

    model_config = ConfigDict(extra="forbid")

    enabled: bool = False
    # The site's own certificate (PEM, with its chain) and key; without them the runtime
    # makes its own certificate authority in the data directory, and a certificate from it
    # for this computer's names and addresses.
    cert_file: Path | None = None
    key_file: Path | None = None
    # Names besides this computer's hostname, hostname.local, localhost and its addresses
    # that the runtime's own certificate is made for.
    names: list[str] = Field(default_factory=list)
    # A plain-HTTP port that sends every request on to the HTTPS UI (80 beside 443).
    redirect_port: int | None = Field(default=None, ge=0, le=65535)

    @model_validator(mode="after")
    def _both_files(self) -> TlsSettings:
        if (self.cert_file is None) != (self.key_file is None):
            raise ValueError("tls: give both cert_file and key_file, or neither")
        return self


class DeviceSpec(BaseModel):
    """A device the launcher starts and supervises: an installed driver (`openpendant driver
    NAME`) with its options."""

    model_config = ConfigDict(extra="forbid")

    driver: str = Field(min_length=1, max_length=32)
    name: str = Field(min_length=1, max_length=64)
    options: dict[str, Any] = Field(default_factory=dict)


def default_devices() -> list[DeviceSpec]:
    """The simulated cell `make run` starts: a UR5 with parts on its table, its I/O block
    (whose `part_present` sees the first part's place) and a Robotiq gripper on its flange
    (the last two on pymodbus's server, driven over the real Modbus protocol)."""
    return [
        DeviceSpec(driver="sim-robot", name="sim-ur5", options={"model": "ur5"}),
        DeviceSpec(
            driver="modbus-io", name="sim-io", options={"simulate": True, "cell": "sim-ur5"}
        ),
        DeviceSpec(
            driver="modbus-gripper",
            name="sim-gripper",
            options={"simulate": True, "profile": "robotiq-2f-85", "mounted_on": "sim-ur5"},
        ),
    ]


class RuntimeSettings(BaseSettings):
    model_config = SettingsConfigDict(
        env_prefix="OPENPENDANT_", env_nested_delimiter="__", extra="forbid"
    )

    host: str = "127.0.0.1"
    port: int = Field(default=8080, ge=0, le=65535)
    # The hold-to-run socket's own port (0: any free one; the UI asks /api/jog/settings):
    # heartbeats go straight to the jog service, never queued behind the gateway's HTTP.
    jog_port: int = Field(default=0, ge=0, le=65535)
    # Names (besides IP addresses, localhost and this computer's hostname[.local]) a browser
    # may use to reach the UI; any other name in a Host header is refused (DNS rebinding).
    allowed_hosts: list[str] = Field(default_factory=list)
    # The largest request body the UI's port accepts (an import of a big variable store).
    max_request_bytes: int = Field(default=16 * 1024 * 1024, ge=64 * 1024, le=1024**3)
    data_dir: Path = Field(default_factory=default_data_dir)
    log_dir: Path | None = None
    log_level: Literal["debug", "info", "warning", "error"] = "info"
    # Start the simulated devices of the `devices` list (--no-sim: only the others).
    sim: bool = True
    devices: list[DeviceSpec] = Field(default_factory=default_devices)
    discovery: DiscoverySettings = Field(default_factory=DiscoverySettings)
    link: LinkSettings = Field(default_factory=LinkSettings)
    programs: ProgramSettings = Field(default_factory=ProgramSettings)
    motion: MotionSettings = Field(default_factory=MotionSettings)
    auth: AuthSettings = Field(default_factory=AuthSettings)
    backups: BackupSettings = Field(default_factory=BackupSettings)
    tls: TlsSettings = Field(default_factory=TlsSettings)
    state_rate_hz: float = Field(default=100.0, gt=0, le=500)
    variable_history: int = Field(default=20, ge=1, le=1000)
    lease_seconds: float = Field(default=15.0, gt=0, le=3600)
    # A process that exits is restarted after `restart_backoff` s, doubled at each exit up
    # to 10 s, and back to the first wait once it has stayed up `restart_healthy_after` s.
    restart_backoff: float = Field(default=0.5, ge=0.01, le=10)
    restart_healthy_after: float = Field(default=30.0, ge=0.5, le=3600)
    # Hold-to-run: the jog service halts a robot when heartbeats stop for this long.
    deadman_seconds: float = Field(default=0.1, ge=0.02, le=0.5)

    @model_validator(mode="before")
    @classmethod
    def _sim_robots(cls, data: Any) -> Any:
        """Configs written before the `devices:` list name their simulated robots in
        `sim_robots:` ({model, name}); each is read as a sim-robot entry (same uuid)."""
        if not isinstance(data, dict) or "sim_robots" not in data:
            return data
        data = dict(data)
        old = data.pop("sim_robots")
        if "devices" in data:
            raise ValueError("give `devices` or the older `sim_robots`, not both")
        if not isinstance(old, list) or not all(isinstance(r, dict) for r in old):
            raise ValueError("sim_robots must be a list of {model, name}")
        data["devices"] = [
            {
                "driver": "sim-robot",
                "name": r.get("name", "sim-ur5"),
                "options": {"model": r.get("model", "ur5")},
            }
            for r in old
        ]
        return data

    @classmethod
    def settings_customise_sources(
        cls,
        settings_cls: type[BaseSettings],
        init_settings: PydanticBaseSettingsSource,
        env_settings: PydanticBaseSettingsSource,
        dotenv_settings: PydanticBaseSettingsSource,
        file_secret_settings: PydanticBaseSettingsSource,
    ) -> tuple[PydanticBaseSettingsSource, ...]:
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if settings_cls.model_config.get("yaml_file"):
            sources.append(YamlConfigSettingsSource(settings_cls))
        return tuple(sources)

    @property
    def logs(self) -> Path:
        return self.log_dir or self.data_dir / "logs"

    def zeroconf_interfaces(self) -> list[str] | Literal["all"]:
        return resolve_interfaces(self.discovery.interfaces, self.host)


def resolve_interfaces(
    choice: Literal["auto", "all"] | list[str], host: str
) -> list[str] | Literal["all"]:
    if choice == "auto":
        return ["127.0.0.1"] if is_loopback(host) else "all"
    return choice


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def load_settings(config_file: Path | None = None, **overrides: Any) -> RuntimeSettings:
    """Settings for a launcher or a standalone driver."""
    overrides = {k: v for k, v in overrides.items() if v is not None}
    if config_file is None:
        return RuntimeSettings(**overrides)
    if not config_file.is_file():
        raise FileNotFoundError(f"config file not found: {config_file}")

    class _FromFile(RuntimeSettings):
        model_config = SettingsConfigDict(yaml_file=config_file)

    return RuntimeSettings.model_validate(_FromFile(**overrides).model_dump())


def settings_for_child(settings: RuntimeSettings) -> dict[str, str]:
    """Environment that hands a child process exactly the launcher's resolved settings."""
    return {SETTINGS_ENV: settings.model_dump_json()}


def settings_from_env() -> RuntimeSettings:
    raw = os.environ.get(SETTINGS_ENV)
    if raw:
        return RuntimeSettings.model_validate(json.loads(raw))
    return RuntimeSettings()
