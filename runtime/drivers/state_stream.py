"""Pushes a driver's state to every subscriber at a fixed rate, serialised once per tick."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from pydantic import BaseModel

from runtime.kit.websocket import Fanout


class StateStream:
    def __init__(self, snapshot: Callable[[], BaseModel], rate_hz: float) -> None:
        self.snapshot = snapshot
        self.period = 1.0 / rate_hz
        self.fanout = Fanout()

    async def run(self) -> None:
        next_tick = time.monotonic()
        last = ""
        while True:
            if self.fanout.subscribers:
                text = self.snapshot().model_dump_json()
                # A state that has not changed since the last tick is not news.
                if text != last:
                    self.fanout.publish(text, key="state")
                    last = text
            next_tick += self.period
            delay = next_tick - time.monotonic()
            if delay < -self.period:
                next_tick = time.monotonic()
                delay = 0.0
            await asyncio.sleep(max(delay, 0.0))
