"""Jog tickets (issue 32): a ticket opens one socket, only while the session or API token
that asked for it stands, and the socket closes when that sign-in ends, however busy it is.
The rules, the store as another process reads it, and the guards on a real ASGI app."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from starlette.applications import Starlette
from starlette.routing import WebSocketRoute
from starlette.testclient import TestClient, WebSocketDenialResponse, WebSocketTestSession
from starlette.websockets import WebSocket, WebSocketDisconnect

from openpendant.runtime.auth.audit import AuditLog
from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.standing import SignIns, Standing
from openpendant.runtime.auth.store import AuthStore, digest
from openpendant.runtime.kit import tickets
from openpendant.runtime.kit.service_guard import TicketRequired
from openpendant.runtime.kit.sign_in_watch import ENDED
from openpendant.webui import access as webui_access
from openpendant.webui.access import SESSION_COOKIE, AccessGuard
from openpendant.webui.auth_routes import auth_router
from tests.unit.test_auth import Clock

UI = "http://127.0.0.1:8080"
PASSWORD = "operator password"


@pytest.fixture
def store(tmp_path: Path) -> Iterator[AuthStore]:
    made = AuthStore(tmp_path / "auth.sqlite", idle_seconds=600, absolute_seconds=3600)
    made.create_user("op", PASSWORD, Role.operator)
    made.create_user("ada", "admin password", Role.admin)
    yield made
    made.close()


def sign_ins(store: AuthStore, clock: Clock | None = None) -> SignIns:
    return SignIns(store.path, idle_seconds=600, absolute_seconds=3600, clock=clock or time.time)


def session_ticket(store: AuthStore, user: str = "op") -> tuple[str, str]:
    """(the session's id digest, a ticket it asked for)."""
    secret, _ = store.open_session(user)
    sid = digest(secret)
    return sid, tickets.issue(user, int(store.role_of(user)), session=sid)


def token_ticket(store: AuthStore, role: Role = Role.operator) -> tuple[str, str]:
    """(the API token's id, a ticket it asked for)."""
    secret = store.create_token("script", role)
    who = store.token(secret)
    assert who is not None and who.token is not None
    return who.token, tickets.issue(who.user, int(role), token=who.token)


# The rules ------------------------------------------------------------------------------------


def test_a_ticket_names_the_one_sign_in_that_asked_for_it() -> None:
    by_session = tickets.check(tickets.issue("op", 2, session="s1", now=100.0), now=101.0)
    assert by_session is not None
    assert (by_session.kind, by_session.sign_in, by_session.user) == ("session", "s1", "op")
    by_token = tickets.check(tickets.issue("token:x", 2, token="t1", now=100.0), now=101.0)
    assert by_token is not None and (by_token.kind, by_token.sign_in) == ("token", "t1")
    assert by_token.expires == 100.0 + tickets.LIFETIME
    for bound in ({}, {"session": "s1", "token": "t1"}):
        with pytest.raises(ValueError, match="one session or one API token"):
            tickets.issue("op", 2, now=100.0, **bound)
    # Two tickets of the same sign-in at the same instant are two tickets.
    first, second = (tickets.issue("op", 2, session="s1", now=100.0) for _ in range(2))
    assert first != second


def test_a_ticket_is_taken_once_and_not_from_before_the_service_started() -> None:
    taken = tickets.Redeemed(started=1000.0)
    ticket = tickets.check(tickets.issue("op", 2, session="s1", now=1010.0), now=1010.0)
    other = tickets.check(tickets.issue("op", 2, session="s1", now=1011.0), now=1011.0)
    older = tickets.check(tickets.issue("op", 2, session="s1", now=990.0), now=1011.0)
    assert ticket is not None and other is not None and older is not None
    assert taken.take(ticket, now=1012.0)
    assert not taken.take(ticket, now=1013.0)
    assert taken.take(other, now=1013.0)
    assert not taken.take(older, now=1013.0)  # a restarted service remembers nothing
    # Long after: the ticket's memory is dropped, and so is the ticket itself.
    later = 1010.0 + tickets.LIFETIME + 1
    assert not taken.take(ticket, now=later)
    assert tickets.check(tickets.issue("op", 2, session="s1", now=1010.0), now=later) is None


def test_the_store_says_whether_a_sign_in_stands_and_why_not(store: AuthStore) -> None:
    clock = Clock()
    clock.now = time.time()
    reader = sign_ins(store, clock)
    try:

        def standing(ticket: str) -> Standing:
            found = tickets.check(ticket)
            assert found is not None
            return reader.standing(found)

        sid, ticket = session_ticket(store)
        assert standing(ticket) == Standing(Role.operator)
        store.close_session(sid)
        assert standing(ticket) == Standing(None, "session_ended")
        _, ticket = session_ticket(store)
        store.set_role("op", Role.viewer)
        assert standing(ticket) == Standing(None, "role_changed")
        _, ticket = session_ticket(store)
        store.delete_user("op")
        assert standing(ticket) == Standing(None, "user_removed")
        _, ticket = session_ticket(store, "ada")
        clock.now += 601  # unused longer than the idle limit
        assert standing(ticket) == Standing(None, "session_expired")
        clock.now -= 601
        token_id, ticket = token_ticket(store)
        assert standing(ticket) == Standing(Role.operator)
        store.revoke_token(token_id)
        assert standing(ticket) == Standing(None, "token_revoked")
    finally:
        reader.close()


def test_a_store_that_cannot_be_read_confirms_nothing(tmp_path: Path) -> None:
    missing = tmp_path / "none" / "auth.sqlite"
    reader = SignIns(missing, idle_seconds=600, absolute_seconds=3600)
    ticket = tickets.check(tickets.issue("op", 2, session="s1"))
    assert ticket is not None
    assert reader.standing(ticket) == Standing(None, "sign_in_unknown")
    assert not missing.exists()  # and it made no store of its own


# The jog port -------------------------------------------------------------------------------


@pytest.fixture
def jog_port(store: AuthStore, tmp_path: Path) -> Iterator[tuple[TestClient, list[int], AuditLog]]:
    """An echo socket behind the jog port's guard, re-checking every 50 ms; `left` gets the
    close code the app saw when its client went."""
    left: list[int] = []

    async def echo(ws: WebSocket) -> None:
        await ws.accept()
        try:
            while True:
                await ws.send_text(await ws.receive_text())
        except WebSocketDisconnect as gone:
            left.append(gone.code)

    audit = AuditLog(tmp_path / "audit.sqlite")
    reader = sign_ins(store)
    app = Starlette(routes=[WebSocketRoute("/jog/ws", echo)])
    guarded = TicketRequired(app, Role.operator, reader, audit, every=0.05)
    yield TestClient(guarded, base_url=UI), left, audit
    reader.close()
    audit.close()


def wait_for(condition: Callable[[], bool], within: float = 10.0) -> None:
    deadline = time.monotonic() + within
    while not condition():
        assert time.monotonic() < deadline, "never happened"
        time.sleep(0.01)


def refused(client: TestClient, ticket: str) -> tuple[int, str]:
    with (
        pytest.raises(WebSocketDenialResponse) as denied,
        client.websocket_connect(f"/jog/ws?ticket={ticket}"),
    ):
        pass
    return denied.value.status_code, denied.value.json()["error"]["code"]


def closed_while_busy(ws: WebSocketTestSession, within: float) -> tuple[int, str] | None:
    """Messages back and forth (a held jog's heartbeats) until the server closes the socket:
    its close code and reason, or None if it stayed open."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        ws.send_text("heartbeat")
        try:
            ws.receive_text()
        except WebSocketDisconnect as closed:
            return closed.code, closed.reason
        time.sleep(0.01)
    return None


def test_a_ticket_opens_one_socket(
    store: AuthStore, jog_port: tuple[TestClient, list[int], AuditLog]
) -> None:
    client, _, _ = jog_port
    _, ticket = session_ticket(store)
    with client.websocket_connect(f"/jog/ws?ticket={ticket}") as ws:
        ws.send_text("hello")
        assert ws.receive_text() == "hello"
    assert refused(client, ticket) == (401, "ticket_used")
    _, viewer = token_ticket(store, Role.viewer)
    assert refused(client, viewer) == (403, "forbidden")
    assert refused(client, "forged.0000") == (401, "unauthenticated")


def test_a_ticket_of_an_ended_sign_in_opens_nothing(
    store: AuthStore, jog_port: tuple[TestClient, list[int], AuditLog]
) -> None:
    client, _, _ = jog_port
    sid, ticket = session_ticket(store)
    store.close_session(sid)  # signed out after the ticket was given
    assert refused(client, ticket) == (401, "session_ended")
    token_id, ticket = token_ticket(store)
    store.revoke_token(token_id)
    assert refused(client, ticket) == (401, "token_revoked")


@pytest.mark.parametrize("end", ["sign_out", "revoke", "role_change", "removal"])
def test_a_busy_jog_socket_closes_when_its_sign_in_ends(
    store: AuthStore, jog_port: tuple[TestClient, list[int], AuditLog], end: str
) -> None:
    client, left, audit = jog_port
    if end == "revoke":
        token_id, ticket = token_ticket(store)
    else:
        sid, ticket = session_ticket(store)
    with client.websocket_connect(f"/jog/ws?ticket={ticket}") as ws:
        assert closed_while_busy(ws, within=0.3) is None  # stays open while it stands
        if end == "revoke":
            store.revoke_token(token_id)
        elif end == "sign_out":
            store.close_session(sid)
        elif end == "role_change":
            store.set_role("op", Role.viewer)
        else:
            store.delete_user("op")
        why = {
            "sign_out": "session_ended",
            "revoke": "token_revoked",
            "role_change": "role_changed",
            "removal": "user_removed",
        }[end]
        assert closed_while_busy(ws, within=10) == (ENDED, why)
        # The app saw its client go (what it drove halts), and the log says why.
        wait_for(lambda: left == [ENDED] and audit.entries(limit=1)[0].action == "CLOSE")
    close = audit.entries(limit=1)[0]
    assert (close.status, close.detail) == (ENDED, {"why": why})


# The gateway's sockets ------------------------------------------------------------------------


def test_a_busy_socket_through_the_gateway_closes_when_its_session_ends(
    store: AuthStore, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A held jog through the gateway sends heartbeats all the time: they must not put off
    the check of its session (they did: it ran only after 2 s without a message)."""
    monkeypatch.setattr(webui_access, "RECHECK_EVERY", 0.05)
    audit = AuditLog(tmp_path / "audit.sqlite")
    app = FastAPI()
    app.include_router(auth_router(store, audit, setup_code=None))

    @app.websocket("/api/jog/ws")
    async def jog(ws: WebSocket) -> None:
        await ws.accept()
        with contextlib.suppress(WebSocketDisconnect):
            while True:
                await ws.send_text(await ws.receive_text())

    app.add_middleware(AccessGuard, store=store, audit=audit)
    client = TestClient(app, base_url=UI)
    signed = client.post("/api/auth/login", json={"user": "op", "password": PASSWORD})
    cookie = {"cookie": f"{SESSION_COOKIE}={signed.cookies[SESSION_COOKIE]}"}
    try:
        with client.websocket_connect("/api/jog/ws", headers=cookie) as ws:
            assert closed_while_busy(ws, within=0.3) is None
            out = client.post(
                "/api/auth/logout", headers={**cookie, "x-csrf-token": signed.json()["csrf"]}
            )
            assert out.status_code == 204
            assert closed_while_busy(ws, within=10) == (ENDED, "session_ended")
            wait_for(lambda: audit.entries(limit=1)[0].action == "CLOSE")
        assert audit.entries(limit=1)[0].detail == {"why": "session_ended"}
    finally:
        audit.close()
