"""Where the runtime keeps its users, and what the launcher and the CLI do with them."""

from __future__ import annotations

from pathlib import Path

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.standing import SignIns
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.kit.settings import RuntimeSettings

SETUP_CODE_ENV = "OPENPENDANT_SETUP_CODE"


def auth_path(data_dir: Path) -> Path:
    return data_dir / "auth.sqlite"


def _session_limits(settings: RuntimeSettings) -> tuple[float, float]:
    """(idle, absolute) in seconds."""
    return settings.auth.session_idle_minutes * 60, settings.auth.session_hours * 3600


def auth_store(settings: RuntimeSettings) -> AuthStore:
    idle, absolute = _session_limits(settings)
    return AuthStore(auth_path(settings.data_dir), idle_seconds=idle, absolute_seconds=absolute)


def sign_ins(settings: RuntimeSettings) -> SignIns:
    """What a service other than the gateway reads of the store: whether a sign-in stands."""
    idle, absolute = _session_limits(settings)
    return SignIns(auth_path(settings.data_dir), idle_seconds=idle, absolute_seconds=absolute)


def create_token(data_dir: Path, role: str, name: str) -> str:
    """`openpendant token create`: a token for scripts, made on the runtime computer (who
    can write its data directory can do anything anyway)."""
    store = AuthStore(auth_path(data_dir))
    try:
        return store.create_token(name, Role.named(role))
    finally:
        store.close()


def needs_setup(data_dir: Path) -> bool:
    store = AuthStore(auth_path(data_dir))
    try:
        return store.user_count() == 0
    finally:
        store.close()
