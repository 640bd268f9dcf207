"""A service's view of the device manager's links, over one socket (`WS /devices/_links`):
every device's link status and generation, the states of the devices it watches, and the
way to command them. Every service uses the same link per device, so the UI, jog, motion
and program always talk to the same device at the same address.

A state is used only while it is fresh (its age under `stale_after`), its link connected
and this socket up; commands name the generation they were meant for, so nothing started on
a link that was lost continues on the next one."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import websockets
from websockets.asyncio.client import ClientConnection

from openpendant.plugins.registry import registry
from openpendant.runtime.kit.errors import OpenPendantError, Unavailable
from openpendant.runtime.kit.internal import internal_headers
from openpendant.runtime.kit.words import link_words, words
from openpendant.runtime.links.freshness import Freshness, state_stamp

log = logging.getLogger(__name__)

MAX_FRAME = 64 << 20
CALL_TIMEOUT = 10.0
RETRY = 0.2
LINK_FAULTS = ("link_stale", "link_changed", "device_disconnected", "device_not_found")

Refusal = Callable[[dict[str, Any]], None]


@dataclass
class DeviceView:
    """One device's link as this service sees it."""

    name: str
    kind: str = ""
    status: str = "connecting"
    generation: int = -1
    url: str = ""
    error: str = ""
    info: dict[str, Any] | None = None
    text: str | None = None  # newest state, as sent
    parsed: Any = None  # ... and parsed, on first use
    freshness: Freshness = field(default_factory=Freshness)
    ready: asyncio.Event = field(default_factory=asyncio.Event)
    on_refused: Refusal | None = None


class LinkHub:
    def __init__(self, device_manager_url: str, service: str, stale_after: float) -> None:
        self.url = device_manager_url.replace("http://", "ws://", 1) + "/devices/_links"
        self.service = service
        self.stale_after = stale_after
        self.views: dict[str, DeviceView] = {}
        self.devices: dict[str, dict[str, Any]] = {}  # the added list, by local name
        self.on_devices: list[Callable[[dict[str, dict[str, Any]]], None]] = []
        self.connected = asyncio.Event()  # the socket is up and its snapshot arrived
        self.handles: dict[tuple[str, str], object] = {}  # one typed handle per device
        self._watching: set[str] = set()
        self._ws: ClientConnection | None = None
        self._task: asyncio.Task[None] | None = None
        self._refs = itertools.count(1)
        self._calls: dict[int, asyncio.Future[tuple[int, Any]]] = {}

    async def start(self) -> None:
        self._task = asyncio.create_task(self._follow(), name=f"links:{self.service}")

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            await asyncio.wait({self._task}, timeout=2.0)

    async def wait_connected(self, timeout: float = 3.0) -> None:
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout):
                await self.connected.wait()
        if not self.connected.is_set():
            raise Unavailable("no link to the device manager", code="device_manager_down")

    # Views -----------------------------------------------------------------------------------

    def view(self, name: str) -> DeviceView:
        view = self.views.get(name)
        if view is None:
            view = self.views[name] = DeviceView(name)
        return view

    async def watch(self, name: str) -> DeviceView:
        view = self.view(name)
        if name not in self._watching:
            self._watching.add(name)
            await self._op({"op": "watch", "devices": sorted(self._watching)}, quiet=True)
        return view

    def state_text(self, view: DeviceView, generation: int | None = None) -> str:
        """The newest state if it can be trusted now, else the reason raised."""
        if not self.connected.is_set():
            raise Unavailable(
                "the link to the device manager is down",
                code="device_disconnected",
                words=words("link.manager_down"),
            )
        if generation is not None and generation != view.generation:
            raise OpenPendantError(
                f"the link to {view.name} was lost and made again; what ran on it has ended",
                code="link_changed",
                status=409,
                words=words("link.changed", device=view.name),
            )
        if view.status != "connected" or view.text is None:
            code = "link_stale" if view.status == "stale" else "device_disconnected"
            if view.status == "removed":
                code = "device_not_found"
            detail = f": {view.error}" if view.error else ""
            said = link_words(view.name, view.status) if code != "device_not_found" else None
            raise Unavailable(f"{view.name} is {view.status}{detail}", code=code, words=said)
        # Only a moving kind's state changes every cycle; other devices repeat theirs at rest.
        declared = registry().kinds.get(view.kind)
        moving = declared is not None and declared.session
        age = view.freshness.age() if moving else view.freshness.silence()
        if age > self.stale_after:
            shown = (
                "no state yet"
                if math.isinf(age)
                else f"its newest state is {age * 1000:.0f} ms old"
            )
            raise Unavailable(
                f"the link to {view.name} is stale: {shown}",
                code="link_stale",
                words=words("link.stale", device=view.name),
            )
        return view.text

    # Commands --------------------------------------------------------------------------------

    async def send(
        self, name: str, generation: int, command: dict[str, Any], claim: str | None = None
    ) -> None:
        message = {"op": "send", "device": name, "gen": generation, "command": command}
        if claim is not None:
            message["claim"] = claim
        await self._op(message)

    async def halt(self, name: str, tag: str | None) -> None:
        await self._op({"op": "halt", "device": name, "tag": tag})

    async def claim(self, name: str, generation: int, claim: str | None = None) -> None:
        await self._op({"op": "claim", "device": name, "gen": generation, "claim": claim})

    async def unclaim(self, name: str, claim: str | None = None) -> None:
        await self._op({"op": "unclaim", "device": name, "claim": claim}, quiet=True)

    async def call(
        self,
        name: str,
        generation: int,
        method: str,
        path: str,
        body: Any = None,
        claim: str | None = None,
        body_text: str | None = None,
    ) -> tuple[int, Any]:
        """A request to the driver; under `claim`, refused once that claim has ended.
        `body_text`: a body already in JSON, which the device manager sends on unparsed."""
        ref = next(self._refs)
        future: asyncio.Future[tuple[int, Any]] = asyncio.get_running_loop().create_future()
        self._calls[ref] = future
        try:
            await self._op(
                {
                    "op": "call",
                    "ref": ref,
                    "device": name,
                    "gen": generation,
                    "method": method,
                    "path": path,
                    "body": body,
                    "body_text": body_text,
                    "claim": claim,
                }
            )
            async with asyncio.timeout(CALL_TIMEOUT):
                return await future
        except TimeoutError:
            raise Unavailable(f"{name} did not answer {method} {path}", code="timeout") from None
        finally:
            self._calls.pop(ref, None)

    async def _op(self, message: dict[str, Any], quiet: bool = False) -> None:
        ws = self._ws
        if ws is None:
            if quiet:
                return
            raise Unavailable(
                "the link to the device manager is down",
                code="device_disconnected",
                words=words("link.manager_down"),
            )
        try:
            await ws.send(json.dumps(message))
        except websockets.WebSocketException as exc:
            if not quiet:
                raise Unavailable(
                    "the link to the device manager is down",
                    code="device_disconnected",
                    words=words("link.manager_down"),
                ) from exc

    # The socket ------------------------------------------------------------------------------

    async def _follow(self) -> None:
        while True:
            try:
                async with websockets.connect(
                    self.url,
                    open_timeout=2.0,
                    close_timeout=0.5,
                    max_size=MAX_FRAME,
                    additional_headers=internal_headers(self.url),
                    compression=None,  # states 100 times a second: CPU, not bytes, is short
                ) as ws:
                    await ws.send(json.dumps({"op": "hello", "service": self.service}))
                    if self._watching:
                        await ws.send(
                            json.dumps({"op": "watch", "devices": sorted(self._watching)})
                        )
                    self._ws = ws
                    async for frame in ws:
                        text = frame if isinstance(frame, str) else frame.decode()
                        for line in text.split("\n"):
                            try:
                                self._line(line)
                            except (ValueError, KeyError, TypeError) as exc:
                                log.warning("bad line on the link socket (%s): %.80s", exc, line)
            except (OSError, websockets.WebSocketException, TimeoutError) as exc:
                log.info("link socket to the device manager dropped: %s", exc)
            except Exception:  # the links must come back whatever went wrong
                log.exception("link socket to the device manager failed")
            finally:
                self._lost()
            await asyncio.sleep(RETRY)

    def _lost(self) -> None:
        self._ws = None
        was_up = self.connected.is_set()
        self.connected.clear()
        for future in self._calls.values():
            if not future.done():
                future.set_exception(
                    Unavailable(
                        "the link to the device manager was lost", code="device_disconnected"
                    )
                )
        if was_up:
            for view in self.views.values():
                self._update(
                    view, status="disconnected", error="the device manager is not reachable"
                )

    def _line(self, line: str) -> None:
        if line.startswith("S "):
            self._state_line(line)
            return
        try:
            message = json.loads(line)
        except ValueError:
            log.warning("malformed line on the link socket: %.80s", line)
            return
        kind = message.get("type")
        if kind == "link":
            self._link(message)
        elif kind == "devices":
            self.devices = {d["local_name"]: d for d in message.get("devices", [])}
            self.connected.set()
            for listener in list(self.on_devices):
                listener(self.devices)
        elif kind == "reply":
            future = self._calls.get(message.get("ref"))
            if future is not None and not future.done():
                future.set_result((int(message.get("status", 500)), message.get("body")))
        elif kind == "refused":
            view = self.views.get(str(message.get("device")))
            if view is not None and view.on_refused is not None:
                view.on_refused(message.get("error") or {})
            else:
                log.info("refused: %s", message.get("error"))

    def _state_line(self, line: str) -> None:
        _, name, generation, text = line.split(" ", 3)
        view = self.views.get(name)
        if view is None or int(generation) != view.generation:
            return  # from a link that has since ended
        stamp = state_stamp(text)
        view.freshness.observe(stamp.seqno, stamp.ts)
        view.text, view.parsed = text, None
        view.ready.set()

    def _link(self, message: dict[str, Any]) -> None:
        view = self.view(str(message.get("device")))
        generation = int(message.get("gen", -1))
        if generation != view.generation:
            view.text, view.parsed = None, None
            view.ready.clear()
            view.freshness.reset()
        self._update(
            view,
            status=str(message.get("status")),
            generation=generation,
            kind=str(message.get("kind", view.kind)),
            url=str(message.get("url", "")),
            error=str(message.get("error", "")),
            info=message.get("info") or view.info,
        )

    def _update(self, view: DeviceView, **changes: Any) -> None:
        for key, value in changes.items():
            setattr(view, key, value)
        if view.status != "connected":
            view.text, view.parsed = None, None
            view.ready.clear()
