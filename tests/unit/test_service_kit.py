"""The app factory's error contract and the WebSocket fan-out."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time

import pytest
from fastapi import APIRouter, FastAPI, WebSocket
from fastapi.testclient import TestClient

from openpendant.runtime.interfaces.common import Pose, Strict
from openpendant.runtime.kit.app import create_app
from openpendant.runtime.kit.errors import Conflict
from openpendant.runtime.kit.request_start import received_at, stamp
from openpendant.runtime.kit.websocket import Fanout, OutboxOverflow, Subscriber


class Body(Strict):
    pose: Pose
    speed: float


def make_app() -> FastAPI:
    app = create_app("test")

    @app.post("/move")
    async def move(body: Body) -> dict[str, float]:
        return {"speed": body.speed}

    @app.get("/busy")
    async def busy() -> None:
        raise Conflict("robot is busy", code="busy")

    @app.get("/crash")
    async def crash() -> None:
        raise RuntimeError("boom")

    return app


def test_health() -> None:
    body = TestClient(make_app()).get("/health").json()
    assert body["status"] == "ok" and body["service"] == "test"


def test_nan_and_infinity_in_a_body_are_a_clear_422() -> None:
    client = TestClient(make_app())
    for raw in (
        '{"pose": {"position": [0, 0, NaN]}, "speed": 1}',
        '{"pose": {"position": [0, 0, 0]}, "speed": Infinity}',
    ):
        response = client.post("/move", content=raw, headers={"content-type": "application/json"})
        assert response.status_code == 422
        error = response.json()["error"]
        assert error["code"] == "invalid_request"
        assert "finite" in error["message"]


def test_bodies_no_parser_can_read_are_a_clear_400() -> None:
    client = TestClient(make_app())
    pose = '{"position": [0, 0, 0]}'
    for raw, says in (
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        (f'{{"pose": {pose}, "speed": {"9" * 5000}}}', "too many digits"),
        (b'{"pose": {"position": [0, 0, 0]}, "speed": "\xff"}', "not UTF-8"),
    ):
        response = client.post("/move", content=raw, headers={"content-type": "application/json"})
        error = response.json()["error"]
        assert response.status_code == 400 and error["code"] == "bad_body", error
        assert says in error["message"]
    json_type = {"content-type": "application/json"}
    huge = client.post("/move", content=f'{{"pose": {pose}, "speed": 1e300}}', headers=json_type)
    assert huge.status_code == 200  # a large but finite float is a value, not an error


def test_domain_errors_unknown_routes_and_crashes_use_the_error_body() -> None:
    client = TestClient(make_app(), raise_server_exceptions=False)
    assert client.get("/busy").status_code == 409
    assert client.get("/busy").json() == {"error": {"code": "busy", "message": "robot is busy"}}
    assert client.get("/nope").json()["error"]["code"] == "not_found"
    crash = client.get("/crash")
    assert crash.status_code == 500 and crash.json()["error"]["code"] == "internal_error"


def test_subscriber_keeps_only_the_newest_state_but_every_event() -> None:
    async def scenario() -> list[str]:
        sub = Subscriber()
        for i in range(100):
            sub.push(f"state {i}", key="state:robot")
        sub.push("event a")
        sub.push("event b")
        return await sub.next_batch()

    assert asyncio.run(scenario()) == ["event a", "event b", "state 99"]


def test_a_subscriber_that_falls_far_behind_is_dropped() -> None:
    async def scenario() -> None:
        sub = Subscriber(max_events=3)
        for i in range(5):
            sub.push(f"event {i}")
        await sub.next_batch()

    try:
        asyncio.run(scenario())
    except OutboxOverflow:
        return
    raise AssertionError("an overflowing subscriber must be dropped")


def test_errors_from_other_services_keep_their_kind() -> None:
    from openpendant.runtime.kit.errors import InvalidValue, NotFound, OpenPendantError

    missing = OpenPendantError.from_body(
        404, {"error": {"code": "variable_not_found", "message": "no variable"}}
    )
    assert isinstance(missing, NotFound)
    assert (missing.code, missing.message, missing.status) == (
        "variable_not_found",
        "no variable",
        404,
    )
    assert isinstance(OpenPendantError.from_body(409, {"error": {}}), Conflict)
    assert isinstance(OpenPendantError.from_body(422, None), InvalidValue)
    assert type(OpenPendantError.from_body(418, None)) is OpenPendantError


def test_state_stream_repeats_a_quiet_state_and_skips_duplicates() -> None:
    from pydantic import BaseModel

    from openpendant.runtime.drivers.state_stream import KEEPALIVE, StateStream
    from openpendant.runtime.kit.websocket import Subscriber

    class Quiet(BaseModel):
        value: int = 1

    async def scenario() -> list[str]:
        stream = StateStream(Quiet, rate_hz=100)
        sub = Subscriber()
        stream.fanout.subscribers.add(sub)
        task = asyncio.create_task(stream.run())
        received: list[str] = []
        deadline = asyncio.get_running_loop().time() + KEEPALIVE * 2.5
        while asyncio.get_running_loop().time() < deadline:
            with contextlib.suppress(TimeoutError):
                received += await asyncio.wait_for(sub.next_batch(), 0.05)
        task.cancel()
        assert stream.current() == Quiet().model_dump_json()
        return received

    received = asyncio.run(scenario())
    # 100 Hz for 0.625 s, but the state never changed: the first send and two keep-alives.
    assert 2 <= len(received) <= 4


def test_state_stream_sends_a_change_at_once_when_the_driver_says_so() -> None:
    """A stream ticking once a minute: a change the driver signals goes out without waiting
    for the tick."""
    from pydantic import BaseModel

    from openpendant.runtime.drivers.state_stream import StateStream
    from openpendant.runtime.kit.websocket import Subscriber

    class Signal(BaseModel):
        value: int = 0

    current = Signal()

    async def scenario() -> list[str]:
        changed = asyncio.Event()
        stream = StateStream(lambda: current, rate_hz=1 / 60, changed=changed)
        sub = Subscriber()
        stream.fanout.subscribers.add(sub)
        task = asyncio.create_task(stream.run())
        first = await asyncio.wait_for(sub.next_batch(), 5)
        current.value = 1
        changed.set()
        second = await asyncio.wait_for(sub.next_batch(), 5)  # not 60 s
        task.cancel()
        return [*first, *second]

    received = asyncio.run(scenario())
    assert [json.loads(r)["value"] for r in received] == [0, 1]


def test_the_request_start_stamp_is_read_only_when_it_is_a_recent_time() -> None:
    now = time.time()
    assert received_at(stamp()) == pytest.approx(now, abs=1.0)
    for bad in (None, "", "soon", "nan", "inf", "1", str(now + 3600), str(now - 3600)):
        assert received_at(bad) is None, bad


def test_an_acknowledged_feed_sends_no_more_than_its_client_takes() -> None:
    """A client that stops acknowledging gets two frames and then nothing more; meanwhile the
    states conflate, so its next frame, after an ack, holds only the newest one."""
    fanout = Fanout()
    app = FastAPI()

    @app.websocket("/feed")
    async def feed(ws: WebSocket) -> None:
        await fanout.serve(ws, acked=True)

    with TestClient(app) as client, client.websocket_connect("/feed") as ws:
        deadline = time.monotonic() + 2
        while not fanout.subscribers:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        frames = []
        for i in range(3):
            fanout.publish(json.dumps({"n": i}), key="state")
            if i < 2:
                frames.append(json.loads(ws.receive_text()))
        for i in range(3, 50):
            fanout.publish(json.dumps({"n": i}), key="state")
        time.sleep(0.1)
        ws.send_text('{"type":"ack"}')
        frames.append(json.loads(ws.receive_text()))
    assert frames == [[{"n": 0}], [{"n": 1}], [{"n": 49}]]


def unbuilt(app: FastAPI) -> list[object]:
    """The included routers whose routes FastAPI has not built yet (it builds them at the
    first request that reaches them, unless they were built before)."""
    return [r for r in app.router.routes if getattr(r, "_effective_candidates_version", 0) is None]


def test_included_routes_are_built_before_the_first_request() -> None:
    """Built at a first request they held the device manager's event loop 100-170 ms."""
    app = create_app("kit-test")
    router = APIRouter()

    @router.put("/items/{name}")
    async def put_item(name: str, body: Pose) -> Pose:
        return body

    app.include_router(router, prefix="/x")
    assert unbuilt(app), "this FastAPI builds them eagerly: nothing is left to test"
    with TestClient(app) as client:
        assert unbuilt(app) == []  # at start-up, before any request
        answer = client.put("/x/items/a", json={"position": [0, 0, 0], "orientation": [0, 0, 0, 1]})
        assert answer.status_code == 200, answer.text
