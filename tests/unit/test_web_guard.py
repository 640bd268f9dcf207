"""The public ports' guard on its own (runtime/kit/web_guard.py): Host, Origin, body type and
size, and the headers every answer carries."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi import FastAPI, Request, WebSocket
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from openpendant.runtime.kit.web_guard import WebGuard, WebPolicy, split_host
from openpendant.webui.proxy import PathRefused, below_prefix, service_path

UI = "http://127.0.0.1:8080"


def guarded(**policy: Any) -> tuple[TestClient, list[bytes]]:
    app = FastAPI()
    seen: list[bytes] = []

    @app.post("/echo")
    async def echo(request: Request) -> dict[str, int]:
        body = await request.body()
        seen.append(body)
        return {"bytes": len(body)}

    @app.get("/page")
    async def page() -> dict[str, str]:
        return {"ok": "yes"}

    @app.websocket("/ws")
    async def ws(socket: WebSocket) -> None:
        await socket.accept()
        await socket.send_text("hello")
        await socket.close()

    app.add_middleware(WebGuard, policy=WebPolicy(ui_port=8080, **policy))
    return TestClient(app, base_url=UI), seen


def test_a_name_that_is_not_this_computers_is_refused() -> None:
    client, _ = guarded(allowed_hosts=["pendant.cell4.example"])
    assert client.get("/page").status_code == 200
    assert client.get("/page", headers={"host": "[::1]:8080"}).status_code == 200
    assert client.get("/page", headers={"host": "localhost:8080"}).status_code == 200
    assert client.get("/page", headers={"host": "PENDANT.cell4.example"}).status_code == 200
    rebound = client.get("/page", headers={"host": "attacker.example:8080"})
    assert rebound.status_code == 400
    assert rebound.json()["error"]["code"] == "host_not_allowed"
    assert client.get("/page", headers={"host": ""}).status_code == 400


def test_another_sites_page_changes_nothing_and_opens_no_socket() -> None:
    client, seen = guarded()
    foreign = {"origin": "http://attacker.example", "content-type": "application/json"}
    refused = client.post("/echo", content=b"{}", headers=foreign)
    assert refused.status_code == 403
    assert refused.json()["error"]["code"] == "origin_not_allowed"
    for origin in ("null", "http://127.0.0.1:9999", "file://", "http://127.0.0.1"):
        response = client.post("/echo", headers={"origin": origin})
        assert response.status_code == 403, origin
    # Another computer's page at the UI's port: an address, but not the one asked.
    for origin, host in (
        ("http://10.0.0.5:8080", "10.0.0.7:8080"),
        ("http://127.0.0.2:8080", "127.0.0.1:8080"),
        ("http://[::1]:8080", "127.0.0.1:8080"),
        ("http://localhost:8080", "10.0.0.7:8080"),  # a page on the tablet itself
    ):
        response = client.post("/echo", headers={"origin": origin, "host": host})
        assert response.status_code == 403, origin
    assert seen == []
    own = client.post("/echo", content=b"{}", headers={**foreign, "origin": UI})
    assert own.status_code == 200
    for origin, host in (
        ("http://10.0.0.7:8080", "10.0.0.7:8080"),
        ("http://[::1]:8080", "[::1]:8080"),
        ("http://LocalHost:8080", "localhost:8080"),
    ):
        own_page = {"origin": origin, "host": host, "content-type": "application/json"}
        response = client.post("/echo", content=b"{}", headers=own_page)
        assert response.status_code == 200, origin
    with pytest.raises(WebSocketDisconnect) as closed:  # noqa: SIM117
        with client.websocket_connect(
            "ws://127.0.0.1:8080/ws", headers={"origin": "http://attacker.example"}
        ):
            pass
    assert closed.value.code == 1008
    with client.websocket_connect("ws://127.0.0.1:8080/ws", headers={"origin": UI}) as ws:
        assert ws.receive_text() == "hello"


def test_bodies_a_foreign_page_could_send_unasked_are_refused() -> None:
    client, seen = guarded()
    for media in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data", ""):
        response = client.post("/echo", content=b"program: x", headers={"content-type": media})
        assert response.status_code == 415, media
        assert "application/json" in response.json()["error"]["message"]
    assert seen == []
    for media in ("application/json", "application/json; charset=utf-8", "application/yaml"):
        assert client.post("/echo", content=b"{}", headers={"content-type": media}).is_success
    assert client.post("/echo").status_code == 200  # no body: nothing to mistake


def test_bodies_are_bounded_with_or_without_a_length() -> None:
    client, seen = guarded(max_body=1000)
    json_type = {"content-type": "application/json"}
    assert client.post("/echo", content=b"1" * 1000, headers=json_type).json() == {"bytes": 1000}
    too_big = client.post("/echo", content=b"1" * 1001, headers=json_type)
    assert too_big.status_code == 413
    assert too_big.json()["error"]["code"] == "too_large"

    def chunks(n: int) -> Any:
        for _ in range(n):
            yield b"1" * 100

    assert client.post("/echo", content=chunks(10), headers=json_type).json() == {"bytes": 1000}
    assert client.post("/echo", content=chunks(11), headers=json_type).status_code == 413
    assert [len(b) for b in seen] == [1000, 1000]


def test_every_answer_forbids_framing_sniffing_and_foreign_scripts() -> None:
    client, _ = guarded(jog_port=8765)
    for response in (
        client.get("/page"),
        client.post("/echo", content=b"x", headers={"content-type": "text/plain"}),
    ):
        assert response.headers["x-content-type-options"] == "nosniff"
        assert response.headers["x-frame-options"] == "DENY"
        csp = response.headers["content-security-policy"]
        assert "frame-ancestors 'none'" in csp
        assert "script-src 'self';" in csp
        assert "ws://127.0.0.1:*" in csp


def test_host_headers_parse_with_ports_and_ipv6() -> None:
    assert split_host("127.0.0.1:8080") == ("127.0.0.1", 8080)
    assert split_host("[::1]:80") == ("::1", 80)
    assert split_host("Pendant") == ("pendant", None)
    with pytest.raises(ValueError, match="no host"):
        split_host("")


def test_the_proxy_never_climbs_out_of_a_services_prefix() -> None:
    assert service_path("robot/state") == "robot/state"
    assert service_path("a b") == "a%20b"
    for bad in ("../openapi.json", "x/../../docs", "./x", "a\\..\\b", "a\n", "\u202eevil"):
        with pytest.raises(PathRefused):
            service_path(bad)


def test_the_path_is_read_whole_not_as_routing_matched_it() -> None:
    assert below_prefix("/api/programs/a/run", "programs") == "a/run"
    assert below_prefix("/api/programs", "programs") == ""
    for full in ("/api/programs/a\n", "/api/programs\n", "/api/programsx/a", "/api/programs/../x"):
        with pytest.raises(PathRefused):
            below_prefix(full, "programs")


def test_a_files_raw_bytes_are_taken_only_at_an_upload_path_within_its_own_bound() -> None:
    app = FastAPI()

    @app.put("/api/files/{name}")
    async def upload(request: Request) -> dict[str, int]:
        return {"bytes": len(await request.body())}

    @app.put("/api/other")
    async def other(request: Request) -> dict[str, int]:
        return {"bytes": len(await request.body())}

    policy = WebPolicy(ui_port=8080, max_body=64, uploads={"/api/files/": 1000})
    app.add_middleware(WebGuard, policy=policy)
    client = TestClient(app, base_url=UI)
    raw = {"content-type": "application/octet-stream", "origin": UI}
    taken = client.put("/api/files/net.onnx", content=b"x" * 900, headers=raw)
    assert taken.status_code == 200 and taken.json() == {"bytes": 900}
    assert client.put("/api/files/net.onnx", content=b"x" * 1001, headers=raw).status_code == 413
    # Not at another path, not by POST, and the types a foreign page sends unasked never.
    assert client.put("/api/other", content=b"x", headers=raw).status_code == 415
    assert client.post("/api/files/net.onnx", content=b"x", headers=raw).status_code == 415
    # JSON there is bounded as anywhere; a file comes with its length, never read unbounded.
    assert client.put("/api/files/x", content=b"{}" * 40, headers={"origin": UI}).status_code == 413

    def chunks() -> Iterator[bytes]:
        yield b"x" * 10

    unsized = client.put("/api/files/net.onnx", content=chunks(), headers=raw)
    assert unsized.status_code == 411 and unsized.json()["error"]["code"] == "length_required"
    assert client.put("/api/other", content=b"{}" * 40, headers={"origin": UI}).status_code == 413
    text = {"content-type": "text/plain", "origin": UI}
    assert client.put("/api/files/net.onnx", content=b"x", headers=text).status_code == 415
    foreign = {**raw, "origin": "http://attacker.example"}
    assert client.put("/api/files/net.onnx", content=b"x", headers=foreign).status_code == 403
