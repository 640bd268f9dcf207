"""The device manager's one link per device (DeviceConnection) against small devices served
in this process over real HTTP and WebSockets: sessions, staleness, moves, cancellation and
where a halt goes."""

from __future__ import annotations

import asyncio
import contextlib
import json
import random
import time
from collections.abc import AsyncIterator, Callable, Coroutine
from typing import Any

import pytest
import uvicorn
from fastapi import FastAPI, Request, Response, WebSocket
from starlette.websockets import WebSocketDisconnect

from openpendant.runtime.device_manager.addresses import RecentAddresses
from openpendant.runtime.device_manager.connection import DeviceConnection
from openpendant.runtime.interfaces.variables import DeviceRecord
from openpendant.runtime.kit.device_auth import HEADER, Verifier
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.serve import listening_socket
from openpendant.runtime.kit.settings import LinkSettings

UUID = "robot-1"
TIMING = LinkSettings(stale_after=0.1, driver_timeout=0.2)


class FakeDevice:
    """A device that says who it is and streams a state every 10 ms (unless paused), and
    counts the sockets open to it."""

    def __init__(self, uuid: str = UUID) -> None:
        self.uuid = uuid
        self.open = {"state": 0, "command": 0}
        self.closed = {"state": 0, "command": 0}
        self.commands: list[dict[str, Any]] = []
        self.halts: list[str | None] = []  # halts by HTTP, outside a session: their signature
        self.paused = False
        self.delay = 0.0  # s added to every state's age
        self.slow_asked = 0
        self.seqno = 0
        self.app = FastAPI()
        self.app.get("/info")(self.info)
        self.app.websocket("/state/ws")(self.states)
        self.app.websocket("/command/ws")(self.command_stream)
        self.app.post("/halt")(self.halt)
        self.app.post("/slow")(self.slow)
        self.sock = listening_socket("127.0.0.1", 0)
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        self.server = uvicorn.Server(uvicorn.Config(self.app, log_config=None, lifespan="off"))
        self._task: asyncio.Task[None] | None = None

    async def info(self) -> dict[str, Any]:
        return {"identity": {"uuid": self.uuid, "kind": "robot", "model": "m", "name": "n"}}

    async def states(self, ws: WebSocket) -> None:
        await ws.accept()
        self.open["state"] += 1
        gone = asyncio.create_task(ws.receive())  # the client's close, even while paused
        try:
            while not gone.done():
                if not self.paused:
                    self.seqno += 1
                    ts = time.time() - self.delay
                    await ws.send_text(f'{{"seqno":{self.seqno},"ts":{ts}}}')
                await asyncio.sleep(0.01)
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass
        finally:
            gone.cancel()
            self.open["state"] -= 1
            self.closed["state"] += 1

    async def slow(self) -> dict[str, Any]:
        self.slow_asked += 1
        await asyncio.sleep(3.0)
        return {}

    async def halt(self, request: Request) -> Response:
        self.halts.append(request.headers.get(HEADER))
        return Response(status_code=204)

    async def command_stream(self, ws: WebSocket) -> None:
        await ws.accept()
        self.open["command"] += 1
        try:
            while True:
                self.commands.append(json.loads(await ws.receive_text()))
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass
        finally:
            self.open["command"] -= 1
            self.closed["command"] += 1

    async def __aenter__(self) -> FakeDevice:
        self._task = asyncio.create_task(self.server.serve(sockets=[self.sock]))
        await until(lambda: self.server.started)
        return self

    async def __aexit__(self, *_: object) -> None:
        self.server.should_exit = True
        assert self._task is not None
        await asyncio.wait({self._task}, timeout=5.0)


def record(url: str) -> DeviceRecord:
    return DeviceRecord(uuid=UUID, local_name="robot", kind="robot", model="m", name="n", url=url)


async def until(check: Callable[[], bool], timeout: float = 3.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.01)


@contextlib.asynccontextmanager
async def connection(
    url: str, secret: str | None = None, timing: LinkSettings = TIMING
) -> AsyncIterator[tuple[DeviceConnection, list[str]]]:
    statuses: list[str] = []
    conn = DeviceConnection(
        record(url),
        lambda *_: None,
        lambda c: statuses.append(c.status),
        timing,
        secret=lambda: secret,
    )
    conn.start()
    try:
        yield conn, statuses
    finally:
        await conn.stop()


def run(scenario: Callable[[], Coroutine[Any, Any, None]]) -> None:
    asyncio.run(scenario())


def test_a_session_holds_the_state_stream_and_a_bound_command_stream() -> None:
    async def scenario() -> None:
        async with FakeDevice() as device, connection(device.url) as (conn, _):
            await until(lambda: conn.status == "connected")
            assert device.open == {"state": 1, "command": 1}
            # Connected once the command socket is open; its first message may still be
            # on its way to the device.
            await until(lambda: bool(device.commands))
            assert device.commands[0]["type"] == "session"
            assert device.commands[0]["timeout"] == TIMING.driver_timeout
            conn.send({"type": "halt"}, conn.generation, lambda _: None)
            await until(lambda: any(c["type"] == "halt" for c in device.commands))
            # A quiet session is kept alive for the driver's watchdog.
            await until(lambda: any(c["type"] == "keepalive" for c in device.commands))

    run(scenario)


def test_a_silent_state_stream_makes_the_link_stale_and_the_next_one_a_new_generation() -> None:
    async def scenario() -> None:
        async with FakeDevice() as device, connection(device.url) as (conn, statuses):
            await until(lambda: conn.status == "connected")
            first = conn.generation
            device.paused = True
            await until(lambda: "stale" in statuses, timeout=1.0)
            assert "no state" in conn.last_error
            # The stale session is ended: nothing is sent on it any more.
            await until(lambda: device.closed == {"state": 1, "command": 1})
            device.paused = False
            await until(lambda: conn.status == "connected", timeout=1.5)
            assert conn.generation == first + 1
            with pytest.raises(OpenPendantError) as refused:
                conn.send({"type": "jog_joint"}, first, lambda _: None)
            assert refused.value.code == "link_changed"

    run(scenario)


def test_a_request_cut_short_by_the_link_going_stale_says_so() -> None:
    """Not "did not answer": the session's end under the request is why it failed."""

    async def scenario() -> None:
        # Stale after 0.5 s here, not 0.1: on a loaded machine the link must not go stale
        # before the request is under way.
        timing = LinkSettings(stale_after=0.5, driver_timeout=1.0)
        async with FakeDevice() as device, connection(device.url, timing=timing) as (conn, _):
            await until(lambda: conn.status == "connected")
            request = asyncio.create_task(conn.call("POST", "/slow", {}, conn.generation))
            await until(lambda: device.slow_asked == 1)
            device.paused = True
            with pytest.raises(OpenPendantError) as failed:
                await request
            assert failed.value.code == "link_stale"
            assert "ended during the request" in failed.value.message
            assert "no state" in failed.value.message

    run(scenario)


def test_late_states_make_the_link_stale() -> None:
    async def scenario() -> None:
        async with FakeDevice() as device, connection(device.url) as (conn, statuses):
            await until(lambda: conn.status == "connected")
            await asyncio.sleep(0.3)  # the offset estimate settles on the fast deliveries
            device.delay = 0.5  # states keep coming, each half a second old
            await until(lambda: "stale" in statuses, timeout=1.0)
            assert "late" in conn.last_error

    run(scenario)


def test_another_device_at_the_address_is_not_connected() -> None:
    async def scenario() -> None:
        async with FakeDevice(uuid="someone-else") as device, connection(device.url) as (conn, _):
            await until(lambda: conn.last_error != "")
            assert conn.status == "disconnected"
            assert "another device" in conn.last_error
            assert device.open == {"state": 0, "command": 0}

    run(scenario)


def test_many_moves_and_stops_leave_no_session_behind() -> None:
    """Moving between two addresses at random moments, and stopping in the middle of
    connecting, closing or streaming: every stop returns at once and leaves no socket open
    (Python 3.11's wait_for could swallow a cancellation and hang a session)."""

    async def scenario() -> None:
        rng = random.Random(7)
        async with FakeDevice() as a, FakeDevice() as b:
            for _ in range(40):
                conn = DeviceConnection(record(a.url), lambda *_: None, lambda _: None, TIMING)
                conn.start()
                for _ in range(rng.randint(0, 4)):
                    await asyncio.sleep(rng.uniform(0.0, 0.03))
                    conn.move_to(rng.choice((a.url, b.url)))
                await asyncio.sleep(rng.uniform(0.0, 0.03))
                started = time.monotonic()
                await conn.stop()
                assert conn._task is not None and conn._task.done()
                assert time.monotonic() - started < 1.0
            await until(lambda: a.open == b.open == {"state": 0, "command": 0}, timeout=1.0)

    run(scenario)


def test_a_stopped_connection_sends_nothing_more() -> None:
    async def scenario() -> None:
        async with FakeDevice() as device:
            async with connection(device.url) as (conn, _):
                await until(lambda: conn.status == "connected")
            await until(lambda: device.open == {"state": 0, "command": 0}, timeout=1.0)
            count = len(device.commands)
            await asyncio.sleep(0.2)
            assert len(device.commands) == count

    run(scenario)


def test_a_halt_goes_to_every_address_the_link_used_in_the_last_minute() -> None:
    """Issue 31: a link moved to an impostor took STOP with it. The address the link left
    still hears the halt, signed as this runtime's; the live session carries it where the
    link is now."""

    async def scenario() -> None:
        async with (
            FakeDevice() as a,
            FakeDevice() as b,
            connection(a.url, secret="pairing-secret") as (conn, _),
        ):
            await until(lambda: conn.live and a.open["command"] == 1)
            conn.move_to(b.url)
            await until(lambda: conn.live and b.open["command"] == 1)
            assert conn.halt("stop")
            await until(lambda: any(c.get("tag") == "stop" for c in b.commands))
            await until(lambda: len(a.halts) == 1)
            # The fake device names no boot id: signed for none.
            assert Verifier("pairing-secret", boot="").check(a.halts[0], "POST", "/halt")
            assert b.halts == []  # its session carried it
            assert not any(c["type"] == "halt" for c in a.commands)

    run(scenario)


def test_a_halt_without_a_live_session_still_reaches_the_address() -> None:
    async def scenario() -> None:
        async with FakeDevice() as device, connection(device.url) as (conn, statuses):
            await until(lambda: conn.status == "connected")
            device.paused = True
            await until(lambda: "stale" in statuses, timeout=1.0)
            assert not conn.halt("stop")  # no session to carry it...
            await until(lambda: len(device.halts) == 1)  # ... but the device hears it

    run(scenario)


def test_an_address_stays_recent_for_a_minute_after_the_link_last_used_it() -> None:
    addresses = RecentAddresses()
    addresses.used("http://10.0.0.1:80", now=100.0)
    addresses.used("http://10.0.0.2:80", now=130.0)
    addresses.used("http://10.0.0.1:80", now=140.0)  # used again: a minute from now on
    assert sorted(addresses.recent(now=189.0)) == ["http://10.0.0.1:80", "http://10.0.0.2:80"]
    assert addresses.recent(now=195.0) == ["http://10.0.0.1:80"]  # .2: 65 s ago
    assert addresses.recent(now=201.0) == []
