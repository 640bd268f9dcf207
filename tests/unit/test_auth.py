"""Users, sessions, tokens and the audit log on their own, and the gateway's sign-in routes
with the access guard in front (a TestClient, as a browser elsewhere would be)."""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.store import AuthStore, LockedOut, Unauthenticated
from openpendant.runtime.kit import tickets
from openpendant.runtime.kit.app import install_error_handlers
from openpendant.runtime.kit.device_auth import WINDOW, Verifier, sign
from openpendant.runtime.kit.errors import Conflict, InvalidValue
from openpendant.webui import policy
from openpendant.webui.access import AccessGuard
from openpendant.webui.auth_routes import auth_router

UI = "http://127.0.0.1:8080"
JSON = "application/json"


class Clock:
    def __init__(self) -> None:
        self.now = 1_000_000.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def store(tmp_path: Path, clock: Clock) -> Iterator[AuthStore]:
    made = AuthStore(tmp_path / "auth.sqlite", idle_seconds=600, absolute_seconds=3600, clock=clock)
    yield made
    made.close()


def test_passwords_are_kept_as_argon2id_hashes_only(store: AuthStore) -> None:
    store.create_user("ada", "correct horse battery", Role.admin)
    raw = sqlite3.connect(store.path).execute("SELECT password FROM users").fetchone()[0]
    assert raw.startswith("$argon2id$") and "correct horse" not in raw
    assert store.verify("ada", "correct horse battery") == Role.admin
    for part in (store.path, store.path.with_name("auth.sqlite-wal")):
        assert part.stat().st_mode & 0o777 == 0o600, part
    with pytest.raises(Unauthenticated):
        store.verify("ada", "wrong password!")
    with pytest.raises(Unauthenticated):
        store.verify("nobody", "correct horse battery")
    with pytest.raises(InvalidValue):
        store.create_user("bob", "short", Role.viewer)
    with pytest.raises(InvalidValue):
        store.create_user("Bob/../x", "long enough password", Role.viewer)


def test_failed_logins_lock_the_user_out_for_longer_each_time(
    store: AuthStore, clock: Clock
) -> None:
    store.create_user("op", "operator password", Role.operator)
    for _ in range(5):
        with pytest.raises(Unauthenticated):
            store.verify("op", "guess guess guess")
    with pytest.raises(LockedOut) as locked:
        store.verify("op", "operator password")  # even the right one, while locked
    assert locked.value.details["retry_after"] == 31
    clock.now += 31
    with pytest.raises(Unauthenticated):
        store.verify("op", "guess again now")
    with pytest.raises(LockedOut) as longer:
        store.verify("op", "operator password")
    assert longer.value.details["retry_after"] == 61
    clock.now += 61
    assert store.verify("op", "operator password") == Role.operator  # and the count resets
    with pytest.raises(Unauthenticated):
        store.verify("op", "one more wrong")


def test_sessions_end_when_idle_at_their_age_and_on_a_new_password(
    store: AuthStore, clock: Clock
) -> None:
    store.create_user("ada", "correct horse battery", Role.admin)
    secret, csrf = store.open_session("ada")
    seen = store.session(secret)
    assert seen is not None and seen.user == "ada" and seen.csrf == csrf
    clock.now += 599
    assert store.session(secret) is not None  # used: the idle clock starts again
    clock.now += 599
    assert store.session(secret) is not None
    clock.now += 601
    assert store.session(secret) is None  # idle too long
    second, _ = store.open_session("ada")
    for _ in range(7):
        clock.now += 500
        assert store.session(second) is not None
    clock.now += 500
    assert store.session(second) is None  # over its absolute age, however busy
    third, _ = store.open_session("ada")
    store.set_password("ada", "a brand new password")
    assert store.session(third) is None
    assert store.session("not a session") is None


def test_api_tokens_are_shown_once_scoped_and_revocable(store: AuthStore) -> None:
    token = store.create_token("nightly check", Role.viewer)
    raw = sqlite3.connect(store.path).execute("SELECT digest FROM tokens").fetchone()[0]
    assert token not in raw
    who = store.token(token)
    assert who is not None and who.role == Role.viewer and who.user == "token:nightly check"
    assert store.token(token + "x") is None
    for bad in ("", "x" * 65, "Prüfung", "a\nb"):
        with pytest.raises(InvalidValue):
            store.create_token(bad, Role.viewer)
    store.revoke_token(store.tokens()[0].id)
    assert store.token(token) is None


def test_the_last_administrator_stays_one(store: AuthStore) -> None:
    store.create_user("ada", "correct horse battery", Role.admin)
    with pytest.raises(Conflict):
        store.set_role("ada", Role.operator)
    with pytest.raises(Conflict):
        store.delete_user("ada")
    with pytest.raises(Conflict):
        store.create_user("eve", "another password", Role.admin, first=True)


def test_the_audit_log_cannot_be_changed(tmp_path: Path) -> None:
    log = AuditLog(tmp_path / "audit.sqlite")
    log.record(user="ada", role="admin", address="10.0.0.7", action="POST", target="/api/x")
    db = sqlite3.connect(tmp_path / "audit.sqlite")
    for statement in ("UPDATE audit SET user = 'eve'", "DELETE FROM audit"):
        with pytest.raises(sqlite3.DatabaseError, match="append-only"):
            db.execute(statement)
    assert [e.user for e in log.entries()] == ["ada"]
    assert '"address": "10.0.0.7"' in log.export_lines()


def test_tickets_are_signed_and_short_lived() -> None:
    ticket = tickets.issue("op", int(Role.operator), token="t1", now=100.0)
    found = tickets.check(ticket, now=120.0)
    assert found is not None and (found.user, found.role) == ("op", 2)
    assert tickets.check(ticket, now=100.0 + tickets.LIFETIME + 1) is None
    payload, signature = ticket.split(".")
    assert tickets.check(f"{payload}.{'0' * len(signature)}", now=120.0) is None
    assert tickets.check("nonsense", now=120.0) is None
    assert tickets.check(f"{payload}.\u00e9{signature[1:]}", now=120.0) is None


def test_the_table_gives_the_rights_a_technician_expects() -> None:
    expected = {
        ("POST", "/devices"): Role.admin,
        ("DELETE", "/devices/robot"): Role.admin,
        ("POST", "/variables/_import"): Role.admin,
        ("GET", "/auth/audit"): Role.admin,
        ("PUT", "/programs/pick"): Role.programmer,
        ("POST", "/jog/robots/robot/teach"): Role.programmer,
        ("PUT", "/variables/frames.robot"): Role.programmer,
        ("POST", "/programs/pick/run"): Role.operator,
        ("POST", "/programs/pick/resume"): Role.operator,
        ("WS", "/jog/ws"): Role.operator,
        ("POST", "/devices/robot/lease"): Role.operator,
        ("POST", "/devices/_stop"): Role.viewer,
        ("POST", "/programs/pick/stop"): Role.viewer,
        ("GET", "/devices/robot/state"): Role.viewer,
        ("POST", "/auth/login"): policy.PUBLIC,
        ("WS", "/devices/_links"): policy.INTERNAL,
        ("POST", "/nonsense/x"): Role.admin,
    }
    assert {key: policy.need(*key) for key in expected} == expected


@pytest.fixture
def gateway(tmp_path: Path, store: AuthStore) -> TestClient:
    app = FastAPI()
    install_error_handlers(app)
    audit = AuditLog(tmp_path / "audit.sqlite")
    app.include_router(auth_router(store, audit, setup_code="1234-5678"))

    @app.post("/api/devices/_stop")
    async def stop() -> dict[str, bool]:
        return {"stopped": True}

    app.add_middleware(AccessGuard, store=store, audit=audit)
    client = TestClient(app, base_url=UI)
    client.audit = audit
    return client


def test_the_first_administrator_needs_the_code_from_another_computer(
    gateway: TestClient, store: AuthStore
) -> None:
    # The test client is not on loopback: the code printed at start is needed.
    assert gateway.get("/api/auth/status").json()["setup_needs_code"] is True
    body = {"user": "ada", "password": "correct horse battery"}
    refused = gateway.post("/api/auth/setup", json=body)
    assert refused.status_code == 403 and store.user_count() == 0
    assert gateway.post("/api/auth/setup", json={**body, "code": "0000-0000"}).status_code == 403
    made = gateway.post("/api/auth/setup", json={**body, "code": "1234-5678"})
    assert made.status_code == 200 and made.json()["role"] == "admin"
    cookie = made.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=strict" in cookie
    again = gateway.post("/api/auth/setup", json={**body, "code": "1234-5678"})
    assert again.status_code == 409  # once only


def test_a_setup_code_in_any_characters_is_a_refusal(gateway: TestClient, store: AuthStore) -> None:
    # Found by schemathesis: non-ASCII made the code comparison raise (500).
    body = r'{"user": "ada", "password": "correct horse battery", "code": "\u008b\ud95d\uddeb"}'
    sent = gateway.post("/api/auth/setup", content=body, headers={"content-type": JSON})
    assert sent.status_code == 403
    assert store.user_count() == 0


def test_a_session_changes_nothing_without_its_csrf_token_and_ends_on_logout(
    gateway: TestClient, store: AuthStore
) -> None:
    store.create_user("op", "operator password", Role.operator)
    signed = gateway.post("/api/auth/login", json={"user": "op", "password": "operator password"})
    csrf = signed.json()["csrf"]
    assert gateway.get("/api/auth/me").json()["user"] == "op"
    refused = gateway.post("/api/devices/_stop")
    assert refused.status_code == 403 and refused.json()["error"]["code"] == "csrf_failed"
    assert gateway.post("/api/devices/_stop", headers={"x-csrf-token": "forged"}).status_code == 403
    assert gateway.post("/api/devices/_stop", headers={"x-csrf-token": csrf}).status_code == 200
    assert gateway.get("/api/auth/users").status_code == 403  # an administrator's
    assert gateway.post("/api/auth/logout", headers={"x-csrf-token": csrf}).status_code == 204
    assert gateway.get("/api/auth/me").status_code == 401
    actions = [e.action for e in gateway.audit.entries()]
    assert actions[:3] == ["LOGOUT", "POST", "LOGIN"]  # newest first


def test_changes_to_users_ask_for_the_password_again(gateway: TestClient, store: AuthStore) -> None:
    store.create_user("ada", "correct horse battery", Role.admin)
    csrf = gateway.post(
        "/api/auth/login", json={"user": "ada", "password": "correct horse battery"}
    ).json()["csrf"]
    new = {"name": "bob", "role": "operator", "password": "bobs password 1"}
    headers = {"x-csrf-token": csrf}
    wrong = gateway.post(
        "/api/auth/users", json={**new, "confirm_password": "x" * 12}, headers=headers
    )
    assert wrong.status_code == 401 and store.role_of("ada") == Role.admin
    assert [u.name for u in store.users()] == ["ada"]
    made = gateway.post(
        "/api/auth/users",
        json={**new, "confirm_password": "correct horse battery"},
        headers=headers,
    )
    assert made.status_code == 201
    assert store.verify("bob", "bobs password 1") == Role.operator
    pin = gateway.put(
        "/api/auth/users/bob",
        json={"pin": "2468", "confirm_password": "correct horse battery"},
        headers=headers,
    )
    assert pin.status_code == 200
    assert (
        gateway.post("/api/auth/pin", json={"user": "bob", "pin": "2468"}).json()["role"]
        == "operator"
    )
    assert gateway.post("/api/auth/pin", json={"user": "ada", "pin": "2468"}).status_code == 401


def test_device_signatures_are_bound_to_method_path_body_process_and_time_and_good_once() -> None:
    verifier = Verifier("the-device-secret", boot="this-process")
    body = b'{"velocity": [0.1, 0, 0, 0, 0, 0]}'
    signed = sign(
        "the-device-secret", "POST", "/jog_joint", boot="this-process", body=body, now=1000.0
    )
    assert not verifier.check(signed, "PUT", "/jog_joint", body, now=1000.0)
    assert not verifier.check(signed, "POST", "/enable", body, now=1000.0)
    # Another body under a genuine header: refused (and that header is used up).
    spent = sign(
        "the-device-secret", "POST", "/jog_joint", boot="this-process", body=body, now=1000.0
    )
    assert not verifier.check(spent, "POST", "/jog_joint", b'{"velocity": [3, 0]}', now=1000.0)
    assert not verifier.check(spent, "POST", "/jog_joint", body, now=1000.0)
    assert not verifier.check(signed, "POST", "/jog_joint", body, now=1000.0 + WINDOW + 1)
    restarted = Verifier("the-device-secret", boot="the-next-process")
    assert not restarted.check(signed, "POST", "/jog_joint", body, now=1000.0)
    assert verifier.check(signed, "POST", "/jog_joint", body, now=1001.0)
    assert not verifier.check(signed, "POST", "/jog_joint", body, now=1002.0)  # replayed
    forged = sign("another-secret", "POST", "/jog_joint", boot="this-process", now=1000.0)
    assert not verifier.check(forged, "POST", "/jog_joint", now=1000.0)
    nan = "nan." + signed.split(".", 2)[2]
    for junk in (None, "", "x.y", "1000.0.nonce." + "0" * 64, "a" * 500, nan, signed + "\u00e9"):
        assert not verifier.check(junk, "POST", "/jog_joint", body, now=1000.0)


@pytest.mark.parametrize(
    ("end", "why"),
    [
        ("elsewhere", "signed_out"),
        ("idle", "expired"),
        ("role", "role_changed"),
        ("password", "password_changed"),
        ("removed", "user_removed"),
    ],
)
def test_a_tablet_whose_session_ended_is_told_why(
    gateway: TestClient, store: AuthStore, clock: Clock, end: str, why: str
) -> None:
    """Issue 32: a tablet dropped to the sign-in screen with no word of why. The refusal
    says it (the sign-in screen words it), as long as the cookie could still be shown."""
    store.create_user("ada", "admin password!", Role.admin)
    store.create_user("op", "operator password", Role.operator)
    signed = gateway.post("/api/auth/login", json={"user": "op", "password": "operator password"})
    other = TestClient(gateway.app, base_url=UI, cookies=dict(gateway.cookies))
    if end == "elsewhere":  # the same session signed out in another window
        other.post("/api/auth/logout", headers={"x-csrf-token": signed.json()["csrf"]})
    elif end == "idle":
        clock.now += 601
    elif end == "role":
        store.set_role("op", Role.viewer)
    elif end == "password":
        store.set_password("op", "a new operator password")
    else:
        store.delete_user("op")
    refused = gateway.get("/api/devices")
    assert refused.status_code == 401
    error = refused.json()["error"]
    assert error["code"] == "session_ended"
    assert error["words"] == {
        "code": "access.session_ended",
        "params": {"why": {"code": f"session.{why}", "params": {}}},
    }
    clock.now += 3601  # long after: a cookie that old is no session anyone remembers
    gateway.get("/api/auth/status")
    store.close_session("unrelated")  # any ending prunes what is older than a session lives
    assert gateway.get("/api/devices").json()["error"]["code"] == "unauthenticated"
