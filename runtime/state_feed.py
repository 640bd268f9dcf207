"""Following one driver's state stream: the latest state, parsed, kept fresh (reconnects)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Generic, TypeVar

import websockets
from pydantic import BaseModel

log = logging.getLogger(__name__)

S = TypeVar("S", bound=BaseModel)


class StateFeed(Generic[S]):
    def __init__(self, url: str, model: type[S], name: str) -> None:
        self.url = url.rstrip("/").replace("http://", "ws://", 1) + "/state/ws"
        self.model = model
        self.name = name
        self.state: S | None = None
        self.ready = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    async def start(self, wait: float = 2.0) -> None:
        self._task = asyncio.create_task(self._follow(), name=f"state:{self.name}")
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.ready.wait(), wait)

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    @property
    def alive(self) -> bool:
        return self.ready.is_set()

    async def _follow(self) -> None:
        while True:
            try:
                async with websockets.connect(
                    self.url, open_timeout=2.0, close_timeout=1.0, max_size=2**22
                ) as ws:
                    async for message in ws:
                        self.state = self.model.model_validate_json(message)
                        self.ready.set()
            except (OSError, websockets.WebSocketException, TimeoutError, ValueError) as exc:
                log.info("state stream of %s dropped: %s", self.name, exc)
            self.state = None
            self.ready.clear()
            await asyncio.sleep(0.2)
