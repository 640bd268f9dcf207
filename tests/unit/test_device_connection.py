"""The device manager's per-device connection task: stopping and moving it."""

from __future__ import annotations

import asyncio
import time

from runtime.device_manager.connection import DeviceConnection
from runtime.variable_storage.types import DeviceRecord

RECORD = DeviceRecord(
    uuid="u1", local_name="robot", kind="robot", model="ur5", name="sim", url="http://127.0.0.1:9"
)


def test_stop_wins_even_while_a_session_is_still_closing() -> None:
    """A session that takes a while to unwind (a WebSocket close handshake) must not swallow
    the cancellation of the connection itself."""
    sessions: list[str] = []

    async def slow_session(url: str) -> None:
        sessions.append(url)
        try:
            await asyncio.sleep(100)
        except asyncio.CancelledError:
            await asyncio.sleep(0.3)
            raise

    async def scenario() -> tuple[bool, float]:
        conn = DeviceConnection(RECORD, lambda *_: None, lambda _: None)
        conn._session = slow_session  # type: ignore[method-assign]
        conn.start()
        await asyncio.sleep(0.05)
        conn.move_to("http://127.0.0.1:10")  # the old session starts closing
        await asyncio.sleep(0.05)
        started = time.monotonic()
        await conn.stop()
        assert conn._task is not None
        return conn._task.done(), time.monotonic() - started

    done, took = asyncio.run(scenario())
    assert done
    assert took < 1.5
    assert sessions == ["http://127.0.0.1:9"]


def test_moving_reconnects_at_the_new_address_at_once() -> None:
    sessions: list[str] = []

    async def session(url: str) -> None:
        sessions.append(url)
        await asyncio.sleep(100)

    async def scenario() -> None:
        conn = DeviceConnection(RECORD, lambda *_: None, lambda _: None)
        conn._session = session  # type: ignore[method-assign]
        conn.start()
        await asyncio.sleep(0.05)
        conn.move_to("http://127.0.0.1:10")
        await asyncio.sleep(0.05)
        await conn.stop()

    asyncio.run(scenario())
    assert sessions == ["http://127.0.0.1:9", "http://127.0.0.1:10"]
