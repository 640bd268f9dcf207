"""WebSocket fan-out with per-subscriber conflation, so a slow client never holds up a fast one."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections import deque
from collections.abc import Awaitable, Callable, Coroutine, Iterable
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from openpendant.runtime.kit.errors import OpenPendantError

ACK = '{"type":"ack"}'
ACK_WINDOW = 2  # frames a client may have unacknowledged


class Credit:
    """Frames a client may still be sent before it acknowledges one."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.left = limit
        self._given = asyncio.Event()

    async def take(self) -> None:
        while self.left == 0:
            self._given.clear()
            await self._given.wait()
        self.left -= 1

    def give(self) -> None:
        self.left = min(self.limit, self.left + 1)  # an ack too many gives nothing
        self._given.set()


class OutboxOverflow(Exception):
    """A subscriber fell too far behind on messages that must not be dropped."""


class Subscriber:
    """Outbox of one socket. Keyed messages replace older ones with the same key (the newest
    state is all a client needs); unkeyed messages are events and queue in order."""

    def __init__(self, max_events: int = 1000, max_rate_hz: float | None = None) -> None:
        self._keyed: dict[str, str] = {}
        self._events: deque[str] = deque()
        self._max_events = max_events
        self._ready = asyncio.Event()
        self.min_interval = 1.0 / max_rate_hz if max_rate_hz else 0.0
        self.overflowed = False

    def push(self, text: str, key: str | None = None) -> None:
        if key is None:
            if len(self._events) >= self._max_events:
                self.overflowed = True
            else:
                self._events.append(text)
        else:
            self._keyed.pop(key, None)
            self._keyed[key] = text
        self._ready.set()

    async def next_batch(self) -> list[str]:
        await self._ready.wait()
        self._ready.clear()
        if self.overflowed:
            raise OutboxOverflow("subscriber too slow")
        batch = list(self._events)
        self._events.clear()
        batch.extend(self._keyed.values())
        self._keyed.clear()
        return batch


class Fanout:
    """Publish text messages to every subscribed WebSocket."""

    def __init__(self) -> None:
        self.subscribers: set[Subscriber] = set()

    def publish(self, text: str, key: str | None = None) -> None:
        for sub in self.subscribers:
            sub.push(text, key)

    def publish_json(self, message: dict[str, Any], key: str | None = None) -> None:
        if self.subscribers:
            self.publish(json.dumps(message), key)

    async def serve(
        self,
        ws: WebSocket,
        initial: Iterable[str] = (),
        *,
        max_rate_hz: float | None = None,
        on_message: Callable[[Any], Awaitable[None]] | None = None,
        acked: bool = False,
    ) -> None:
        """Accept the socket and pump messages until either side closes. `acked`: each
        frame is a JSON array of the messages gathered since the last, and the next frame
        goes only when the client has acknowledged one (`{"type": "ack"}`) of the last
        ACK_WINDOW: a client gets states as fast as it takes them (a browser, once per frame
        it draws), and what it cannot take is conflated, never queued."""
        await ws.accept()
        sub = Subscriber(max_rate_hz=max_rate_hz)
        for text in initial:
            sub.push(text)
        self.subscribers.add(sub)
        try:
            await _pump(ws, sub, on_message, acked)
        finally:
            self.subscribers.discard(sub)


async def _pump(
    ws: WebSocket,
    sub: Subscriber,
    on_message: Callable[[Any], Awaitable[None]] | None,
    acked: bool = False,
) -> None:
    credit = Credit(ACK_WINDOW)

    async def send_loop() -> None:
        while True:
            if acked:
                await credit.take()
            batch = await sub.next_batch()
            started = time.monotonic()
            if acked:
                await ws.send_text("[" + ",".join(batch) + "]")
            else:
                for text in batch:
                    await ws.send_text(text)
            if sub.min_interval:
                await asyncio.sleep(max(0.0, sub.min_interval - (time.monotonic() - started)))

    async def receive_loop() -> None:
        while True:
            text = await ws.receive_text()
            if acked and text == ACK:
                credit.give()
                continue
            if on_message is None:
                continue
            try:
                message = json.loads(text)
            except ValueError:
                await send_error(ws, OpenPendantError("message is not JSON", code="bad_message"))
                continue
            try:
                await on_message(message)
            except OpenPendantError as err:
                await send_error(ws, err)

    await until_either_ends(ws, send_loop(), receive_loop())


async def until_either_ends(
    ws: WebSocket, *loops: Coroutine[Any, Any, None], expected: tuple[type[BaseException], ...] = ()
) -> None:
    """Run a socket's loops until one of them ends (its peer left, it fell behind, a send
    failed), then stop the others and close the socket. Those endings are normal."""
    tasks = [asyncio.create_task(loop) for loop in loops]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(
                asyncio.CancelledError,
                WebSocketDisconnect,
                OutboxOverflow,
                RuntimeError,
                OSError,
                *expected,
            ):
                await task
        with contextlib.suppress(RuntimeError, OSError, WebSocketDisconnect):
            await ws.close()


async def send_error(ws: WebSocket, err: OpenPendantError) -> None:
    await ws.send_text(json.dumps({"type": "error", **err.body()}))
