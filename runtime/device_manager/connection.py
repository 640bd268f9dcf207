"""One added device's link: fetch its description, follow its state stream, reconnect with
back-off, and move to a new address when discovery reports one."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections.abc import Callable
from typing import Any

import httpx
import websockets

from runtime.device_manager.models import ConnectionStatus
from runtime.variable_storage.types import DeviceRecord

log = logging.getLogger(__name__)

# A stream silent for this long counts as a dropped connection.
STALE_AFTER = 1.0
BACKOFF = (0.2, 0.5, 1.0, 2.0, 5.0)
CLOSE_TIMEOUT = 1.0


class WrongDevice(Exception):
    pass


class DeviceConnection:
    def __init__(
        self,
        record: DeviceRecord,
        on_state: Callable[[DeviceConnection, str], None],
        on_status: Callable[[DeviceConnection], None],
    ) -> None:
        self.record = record
        self.status: ConnectionStatus = "connecting"
        self.last_error = ""
        self.connected_since: float | None = None
        self.info: dict[str, Any] | None = None
        self.last_state: str | None = None
        self._on_state = on_state
        self._on_status = on_status
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    @property
    def name(self) -> str:
        return self.record.local_name

    def start(self) -> None:
        self._task = asyncio.create_task(self._run(), name=f"device:{self.name}")

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            await asyncio.wait({self._task}, timeout=CLOSE_TIMEOUT * 2)

    def move_to(self, url: str) -> None:
        """Discovery saw this device at a new address: reconnect there now."""
        self.record = self.record.model_copy(update={"url": url})
        self._wake.set()

    def _set_status(self, status: ConnectionStatus, error: str = "") -> None:
        changed = status != self.status or error != self.last_error
        self.status = status
        self.last_error = error
        self.connected_since = time.time() if status == "connected" else None
        if status != "connected":
            self.last_state = None
        if changed:
            self._on_status(self)

    async def _run(self) -> None:
        attempt = 0
        while True:
            self._wake.clear()
            url = self.record.url
            self._set_status("connecting", self.last_error)
            error = await self._until_closed_or_moved(url)
            if self.status == "connected":
                attempt = 0
            self._set_status("disconnected", error)
            delay = 0.0 if self._wake.is_set() else BACKOFF[min(attempt, len(BACKOFF) - 1)]
            attempt += 1
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wake.wait(), delay)

    async def _until_closed_or_moved(self, url: str) -> str:
        session = asyncio.create_task(self._session(url))
        wake = asyncio.create_task(self._wake.wait())
        try:
            await asyncio.wait({session, wake}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            wake.cancel()
            if not session.done():
                session.cancel()
                # asyncio.wait, unlike awaiting the task, never swallows our own cancellation.
                await asyncio.wait({session})
            if not session.cancelled():
                session.exception()  # looked at, even if we are being cancelled ourselves
        if session.cancelled():
            return f"moved to {self.record.url}"
        exc = session.exception()
        if exc is None:
            return "connection closed"
        if isinstance(exc, WrongDevice):
            return str(exc)
        if isinstance(
            exc,
            OSError | httpx.HTTPError | websockets.WebSocketException | TimeoutError | ValueError,
        ):
            return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise exc

    async def _session(self, url: str) -> None:
        async with httpx.AsyncClient(base_url=url, timeout=2.0) as http:
            response = await http.get("/info")
            response.raise_for_status()
            info = response.json()
        uuid = info.get("identity", {}).get("uuid") if isinstance(info, dict) else None
        if uuid != self.record.uuid:
            raise WrongDevice(f"another device (uuid {uuid!r}) answers at {url}")
        self.info = info
        ws_url = url.replace("http://", "ws://", 1).replace("https://", "wss://", 1)
        async with websockets.connect(
            f"{ws_url}/state/ws", open_timeout=2.0, close_timeout=CLOSE_TIMEOUT, max_size=2**22
        ) as ws:
            while True:
                try:
                    message = await asyncio.wait_for(ws.recv(), STALE_AFTER)
                except TimeoutError:
                    raise TimeoutError(f"no state from the device for {STALE_AFTER} s") from None
                text = message if isinstance(message, str) else message.decode()
                json.loads(text)  # a malformed message ends the session
                if self.status != "connected":
                    self._set_status("connected")
                self.last_state = text
                self._on_state(self, text)
