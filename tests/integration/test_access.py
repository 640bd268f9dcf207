"""Every route of every service's OpenAPI schema, and every WebSocket, against the role table
(webui/policy.py) on a running runtime: anonymous gets 401 (a socket is refused before it
is accepted), each role exactly its rights; services answer only the runtime."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import ClientConnection, connect

from openpendant.runtime.auth.roles import Role
from openpendant.runtime.auth.setup import auth_path, create_token
from openpendant.runtime.auth.store import AuthStore
from openpendant.runtime.bench.harness.processes import Runtime, wait_for
from openpendant.runtime.kit.settings import RuntimeSettings
from openpendant.runtime.services import all_services, load_factory
from openpendant.webui import policy
from tests.support.sign_in import revoke_token, sign_out, signed_in

# No real-time margins here: runs alongside the rest (tests/suite.py).
pytestmark = pytest.mark.concurrent

ROLES = ("viewer", "operator", "programmer", "admin")
REFUSALS = {"unauthenticated", "forbidden", "csrf_failed", "internal_only"}


@pytest.fixture(scope="module")
def runtime(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Runtime]:
    proc = Runtime(tmp_path_factory.mktemp("access"), extra=["--no-sim"])
    proc.wait_ready()
    yield proc
    proc.stop()
    # Refusing a socket is no error of the service's (each refused jog ticket logged one).
    assert proc.service_errors() == []


def service_apps() -> dict[str, FastAPI]:
    settings = RuntimeSettings(sim=False)
    urls = {name: "http://127.0.0.1:1" for name in all_services()}
    return {
        name: load_factory(spec)(settings, urls)
        for name, spec in all_services().items()
        if name != "webui"
    }


def sockets(app: FastAPI) -> list[str]:
    def walk(routes: list[Any]) -> Iterator[Any]:
        for route in routes:
            inner = getattr(route, "original_router", None)
            if inner is not None:
                yield from walk(inner.routes)
            else:
                yield route

    return [r.path for r in walk(app.router.routes) if "WebSocket" in type(r).__name__]


def concrete(path: str) -> str:
    return re.sub(r"\{[^}]+\}", "x", path)


def service_routes(runtime: Runtime) -> list[tuple[str, str]]:
    """(method, path below /api) of every service's live OpenAPI schema."""
    found = []
    services = runtime.api("GET", "/health").json()["services"]
    for name, info in services.items():
        if name == "webui":
            continue
        schema = httpx.get(f"{info['url']}/openapi.json", headers=runtime.internal()).json()
        for path, operations in schema["paths"].items():
            if path == "/health":
                continue
            found += [(method.upper(), concrete(path)) for method in operations]
    return found


def gateway_routes(runtime: Runtime) -> list[tuple[str, str]]:
    schema = httpx.get(f"{runtime.url}/openapi.json", headers=runtime.auth()).json()
    found = []
    for path, operations in schema["paths"].items():
        if path.startswith("/api/") and "{prefix}" not in path:
            found += [(method.upper(), concrete(path[4:])) for method in operations]
    return found


def call(runtime: Runtime, method: str, path: str, role: str | None) -> httpx.Response:
    body: dict[str, Any] = {"json": {}} if method in ("POST", "PUT", "PATCH", "DELETE") else {}
    return runtime.api(method, path, role=role, **body)


def code_of(response: httpx.Response) -> str:
    try:
        return str(response.json()["error"]["code"])
    except (ValueError, KeyError, TypeError):
        return ""


def test_every_route_answers_each_role_exactly_its_rights(runtime: Runtime) -> None:
    routes = service_routes(runtime) + gateway_routes(runtime)
    assert len(routes) > 50
    unnamed = [r for r in routes if not policy.named(*r) and r[0] not in ("GET", "HEAD")]
    assert unnamed == [], "every route that changes something needs a line in webui/policy.py"
    wrong: list[tuple[str, str, str | None, int]] = []
    for method, path in routes:
        need = policy.need(method, path)
        anonymous = call(runtime, method, path, None)
        if need == policy.PUBLIC:
            if code_of(anonymous) in REFUSALS:
                wrong.append((method, path, None, anonymous.status_code))
            continue
        if anonymous.status_code != 401:
            wrong.append((method, path, None, anonymous.status_code))
        for role in ROLES:
            answer = call(runtime, method, path, role)
            allowed = isinstance(need, Role) and Role.named(role) >= need
            refused = code_of(answer) in REFUSALS
            if allowed == refused or (not allowed and answer.status_code != 403):
                wrong.append((method, path, role, answer.status_code))
    assert wrong == []


def test_every_socket_is_closed_before_it_is_accepted_unless_the_role_may_use_it(
    runtime: Runtime,
) -> None:
    paths = sorted({p for app in service_apps().values() for p in sockets(app)})
    assert {"/jog/ws", "/devices/ws", "/programs/_ws", "/variables/_events"} <= set(paths)
    for path in paths:
        need = policy.need("WS", path)
        with pytest.raises(InvalidStatus):
            connect(runtime.ws_url(path), open_timeout=5)
        for role in ROLES:
            allowed = isinstance(need, Role) and Role.named(role) >= need
            if allowed:
                with connect(runtime.ws_url(path), additional_headers=runtime.auth(role)):
                    pass
            else:
                with pytest.raises(InvalidStatus) as refused:
                    connect(runtime.ws_url(path), additional_headers=runtime.auth(role))
                assert refused.value.response.status_code in (403, 404), (path, role)


def closed_code(ws: ClientConnection, within: float) -> int | None:
    """The close code the runtime ends the socket with (messages before it are read)."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            ws.recv(timeout=max(0.1, deadline - time.monotonic()))
        except TimeoutError:
            break
        except ConnectionClosed as closed:
            return closed.rcvd.code if closed.rcvd is not None else None
    return None


def test_an_open_socket_ends_with_the_sign_in_that_opened_it(runtime: Runtime) -> None:
    name, password = runtime.user("operator")
    login = httpx.post(
        f"{runtime.url}/api/auth/login", json={"user": name, "password": password}, timeout=10
    )
    cookie = {"Cookie": f"op_session={login.cookies['op_session']}"}
    with connect(runtime.ws_url("/devices/ws"), additional_headers=cookie) as ws:
        ws.recv(timeout=5)  # open and streaming
        out = runtime.api(
            "POST",
            "/auth/logout",
            role=None,
            headers={**cookie, "x-csrf-token": login.json()["csrf"]},
        )
        assert out.status_code == 204
        assert closed_code(ws, within=10) == 4401
    store = AuthStore(auth_path(runtime.data_dir))
    try:
        token = store.create_token("socket-script", Role.programmer)
        bearer = {"Authorization": f"Bearer {token}"}
        with connect(runtime.ws_url("/programs/_ws"), additional_headers=bearer) as ws:
            assert closed_code(ws, within=3) is None  # stays open while the token lives
            store.revoke_token(next(t.id for t in store.tokens() if t.name == "socket-script"))
            assert closed_code(ws, within=10) == 4401
    finally:
        store.close()


def test_the_jog_port_wants_an_operators_ticket(runtime: Runtime) -> None:
    port = runtime.api("GET", "/jog/settings").json()["socket_port"]
    url = f"ws://127.0.0.1:{port}/jog/ws"
    for ticket in ("", "?ticket=forged.0000", "?ticket=" + "x" * 40):
        with pytest.raises(InvalidStatus):
            connect(url + ticket, open_timeout=5)
    refused = runtime.api("POST", "/auth/ticket", role="viewer")
    assert refused.status_code == 403
    assert refused.json()["error"]["message"] == "a viewer may not do this (an operator may)"
    ticket = runtime.api("POST", "/auth/ticket", role="operator").json()["ticket"]
    with connect(f"{url}?ticket={ticket}"):
        pass

    def jog_entries() -> list[tuple[str, str, str]]:
        entries = runtime.api("GET", "/auth/audit").json()
        return [(e["action"], e["user"], e["role"]) for e in entries if e["target"] == "/jog/ws"]

    # The gateway never sees this port: the jog service writes its sockets to the audit log.
    operator = ("token:tests-operator", "operator")
    wait_for(lambda: jog_entries()[:2] == [("CLOSE", *operator), ("OPEN", *operator)], 10)


def jog_port_url(runtime: Runtime, ticket: str) -> str:
    port = runtime.api("GET", "/jog/settings").json()["socket_port"]
    return f"ws://127.0.0.1:{port}/jog/ws?ticket={ticket}"


def ticket_of(runtime: Runtime, sign_in: dict[str, str]) -> str:
    return str(runtime.api("POST", "/auth/ticket", role=None, headers=sign_in).json()["ticket"])


def jog_port_refusal(runtime: Runtime, ticket: str) -> tuple[int, str]:
    with pytest.raises(InvalidStatus) as refused:
        connect(jog_port_url(runtime, ticket), open_timeout=5)
    answer = refused.value.response
    return answer.status_code, json.loads(answer.body or b"{}").get("error", {}).get("code", "")


def test_a_jog_ticket_opens_one_socket(runtime: Runtime) -> None:
    ticket = ticket_of(runtime, runtime.auth("operator"))
    with connect(jog_port_url(runtime, ticket)):
        pass
    assert jog_port_refusal(runtime, ticket) == (401, "ticket_used")


def test_a_jog_ticket_dies_with_the_sign_in_that_asked_for_it(runtime: Runtime) -> None:
    session = signed_in(runtime, "operator")
    ticket = ticket_of(runtime, session)
    sign_out(runtime, session)
    assert jog_port_refusal(runtime, ticket) == (401, "session_ended")
    secret = create_token(runtime.data_dir, "operator", "ticket-script")
    ticket = ticket_of(runtime, {"Authorization": f"Bearer {secret}"})
    revoke_token(runtime, "ticket-script")
    assert jog_port_refusal(runtime, ticket) == (401, "token_revoked")


def test_services_answer_only_the_runtime(runtime: Runtime) -> None:
    services = runtime.api("GET", "/health").json()["services"]
    for name, info in services.items():
        if name == "webui":
            continue
        assert httpx.get(f"{info['url']}/health").status_code == 200
        for path in ("/openapi.json", "/docs"):
            refused = httpx.get(f"{info['url']}{path}")
            assert refused.status_code == 403, (name, path)
            assert code_of(refused) == "internal_only"
        forged = {"X-OpenPendant-Internal": "guess", "X-OpenPendant-Role": "admin"}
        assert httpx.get(f"{info['url']}/openapi.json", headers=forged).status_code == 403


def test_the_gateways_docs_are_for_administrators(runtime: Runtime) -> None:
    for path in ("/docs", "/openapi.json"):
        assert httpx.get(runtime.url + path).status_code == 401
        assert httpx.get(runtime.url + path, headers=runtime.auth("programmer")).status_code == 403
        assert httpx.get(runtime.url + path, headers=runtime.auth("admin")).status_code == 200


def test_forwarded_headers_grant_nothing(runtime: Runtime) -> None:
    claims = {
        "X-Forwarded-For": "127.0.0.1",
        "X-OpenPendant-Role": "admin",
        "X-OpenPendant-User": "admin",
        "X-OpenPendant-Internal": "x",
    }
    assert runtime.api("GET", "/devices", role=None, headers=claims).status_code == 401
    refused = runtime.api("POST", "/devices", role="operator", headers=claims, json={})
    assert refused.status_code == 403
