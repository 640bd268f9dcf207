"""Pushes a driver's state to every subscriber at a fixed rate, serialised once per tick,
and at once when the driver says it changed."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from pydantic import BaseModel

from openpendant.runtime.kit.websocket import Fanout

# An unchanged state is repeated this often, so a quiet device is not taken for a dead or
# stale one (the runtime calls a link stale after 0.2 s without a state).
KEEPALIVE = 0.05


class StateStream:
    def __init__(
        self,
        snapshot: Callable[[], BaseModel],
        rate_hz: float,
        changed: asyncio.Event | None = None,
    ) -> None:
        self.snapshot = snapshot
        self.period = 1.0 / rate_hz
        self.changed = changed
        self.fanout = Fanout()

    def current(self) -> str:
        """For a new subscriber: the state now, before the next change."""
        return self.snapshot().model_dump_json()

    async def run(self) -> None:
        next_tick = time.monotonic()
        last, sent = "", 0.0
        while True:
            if self.fanout.subscribers:
                text = self.snapshot().model_dump_json()
                now = time.monotonic()
                if text != last or now - sent >= KEEPALIVE:
                    self.fanout.publish(text, key="state")
                    last, sent = text, now
            next_tick += self.period
            delay = next_tick - time.monotonic()
            if delay < -self.period:
                next_tick = time.monotonic()
                delay = 0.0
            if self.changed is None:
                await asyncio.sleep(max(delay, 0.0))
                continue
            self.changed.clear()
            try:
                # Not wait_for: in Python 3.11 it swallows a cancel that comes with a change.
                async with asyncio.timeout(max(delay, 0.0)):
                    await self.changed.wait()
            except TimeoutError:
                continue
            next_tick = time.monotonic()  # a change: out now, and the ticks go on from here
