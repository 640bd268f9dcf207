"""An open socket lives only as long as the sign-in that opened it. From the socket's
acceptance on, the sign-in is checked every `every` s whatever the socket carries (a held
jog's heartbeats never put the check off); once it is over, the client is sent close code
ENDED with the reason and the app behind sees the client leave (its receive answers a
disconnect), so whatever the socket drove stops as it does when a client goes."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from starlette.types import Message, Receive, Send

ENDED = 4401  # close code: the socket's sign-in ended
CLOSING = 2.0  # s a close for the sign-in may take once the app is done

# Why the sign-in is over (a short code for the client and the audit log), or None.
Check = Callable[[], Awaitable[str | None]]

log = logging.getLogger(__name__)


class EndsWithSignIn:
    def __init__(self, check: Check, every: float, receive: Receive, send: Send) -> None:
        self._check, self._every = check, every
        self._receive, self._send = receive, send
        self._pending: asyncio.Future[Message] | None = None
        self._over: asyncio.Future[None] | None = None
        self._watch: asyncio.Task[None] | None = None
        self._closed = False
        self.why: str | None = None  # set once the socket was closed for its sign-in

    def _over_future(self) -> asyncio.Future[None]:
        if self._over is None:
            self._over = asyncio.get_running_loop().create_future()
        return self._over

    async def _watching(self) -> None:
        while True:
            await asyncio.sleep(self._every)
            try:
                why = await self._check()
            except Exception:
                log.exception("checking a socket's sign-in failed")
                why = "sign_in_unknown"  # what cannot be confirmed does not stand
            if why is not None:
                break
        self.why = why
        # The app hears first, before the close handshake (which a client may drag out),
        # and nothing the client sends from now on reaches it.
        over = self._over_future()
        if not over.done():
            over.set_result(None)
        if not self._closed:
            self._closed = True
            with contextlib.suppress(Exception):
                await self._send({"type": "websocket.close", "code": ENDED, "reason": why})

    async def receive(self) -> Message:
        over = self._over_future()
        if self._pending is None and not over.done():
            self._pending = asyncio.ensure_future(self._receive())
        if self._pending is not None:
            waiting: set[asyncio.Future[Any]] = {self._pending, over}
            await asyncio.wait(waiting, return_when=asyncio.FIRST_COMPLETED)
            if not over.done():
                message, self._pending = self._pending.result(), None
                return message
            self._pending.cancel()
            self._pending = None
        return {"type": "websocket.disconnect", "code": ENDED}

    async def send(self, message: Message) -> None:
        if self._closed:
            return  # closed for its sign-in: what the app still had to say goes nowhere
        if message["type"] == "websocket.close":
            self._closed = True
        await self._send(message)
        if message["type"] == "websocket.accept" and self._watch is None:
            self._watch = asyncio.create_task(self._watching())

    async def stop(self) -> None:
        """The app is done with the socket: no more checks (a close under way is let
        finish, so the client learns why)."""
        if self._watch is not None and self.why is not None:
            await asyncio.wait({self._watch}, timeout=CLOSING)
        for task in (self._watch, self._pending):
            if task is not None and not task.done():
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
