"""One added device's link: the only connection the runtime has to it. A session fetches the
device's description, follows its state stream and, for a robot, holds the command stream
every service's commands go through (bound as the runtime's session: the driver halts the
robot when it closes or goes silent). A session whose states stop or arrive late is stale:
it is ended at once, and the next one is a new generation, on which nothing of the old one
continues. Sessions restart with a short back-off, and move when the address does. A halt
goes to the live session and, signed, to every other address the link used in the last
minute (runtime/device_manager/addresses.py)."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import logging
import re
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from typing import Any, Literal

import httpx
import websockets
from websockets.asyncio.client import ClientConnection
from websockets.exceptions import InvalidStatus

from openpendant.plugins.registry import registry
from openpendant.runtime.device_manager.addresses import (
    RecentAddresses,
    halt_at,
    halt_route,
    unsettled,
)
from openpendant.runtime.device_manager.models import ConnectionStatus
from openpendant.runtime.device_manager.tools import send_tool_setup
from openpendant.runtime.interfaces.endpoints import endpoints
from openpendant.runtime.interfaces.robot import Robot
from openpendant.runtime.interfaces.variables import DeviceRecord
from openpendant.runtime.kit.client import CLIENT_TLS
from openpendant.runtime.kit.device_auth import HEADER, DeviceAuth
from openpendant.runtime.kit.discovery import clean_text
from openpendant.runtime.kit.errors import OpenPendantError, Unavailable
from openpendant.runtime.kit.settings import LinkSettings
from openpendant.runtime.kit.words import link_words, words
from openpendant.runtime.links.freshness import Freshness, state_stamp

log = logging.getLogger(__name__)

# A state saying the robot is in a protective stop (found without parsing the whole state).
PROTECTIVE_STOP = re.compile(r'"protective_stop"\s*:\s*true')


Capability = Literal["session", "tool", "frames"]


def declares(kind: str, capability: Capability) -> bool:
    """Whether the kind declares it (plugins/api.py `DeviceKind`): a `session` (devices
    that move: an ordered command session the driver halts on when it closes or goes
    silent, and states that must stay fresh), a `tool` setup (applied on every connect,
    and a slow start), or `frames` (pictures the device manager relays)."""
    declared = registry().kinds.get(kind)
    return declared is not None and bool(getattr(declared, capability))


RETRY = (0.1, 0.25, 0.5)  # s between attempts; a returning device is met within 0.5 s
CONNECT_TIMEOUT = 1.0
CALL_TIMEOUT = 5.0
JSON_TYPE = {"content-type": "application/json"}
MAX_INFO = 256 * 1024  # bytes of GET /info
MAX_STATE = 1 << 20  # bytes of one state message
MAX_STREAMED = 1 << 24  # bytes of one streamed message (an image): the gateway's bound too
MAX_ERROR = 300  # characters of a shown error
MAX_QUEUED = 1000  # commands waiting for a slow link: more means it is not a link any more
MAX_ROUTED = 4096  # recent command ids whose refusals go back to their sender

Refusal = Callable[[dict[str, Any]], None]
ToolLoader = Callable[[str], Awaitable[dict[str, Any] | None]]
# Generations count up from this process's start time (ms), so a restarted device manager
# never hands out a generation a service could still hold from before.
GENERATION_BASE = int(time.time() * 1000)


class WrongDevice(Exception):
    pass


class SessionEnded(Exception):
    def __init__(self, reason: str, *, stale: bool = False) -> None:
        super().__init__(reason)
        self.stale = stale


def short(text: str) -> str:
    return clean_text(text, MAX_ERROR)


class DeviceConnection:
    def __init__(
        self,
        record: DeviceRecord,
        on_state: Callable[[DeviceConnection, str], None],
        on_status: Callable[[DeviceConnection], None],
        timing: LinkSettings | None = None,
        tool_setup: ToolLoader | None = None,
        secret: Callable[[], str | None] = lambda: None,
    ) -> None:
        self.record = record
        self._secret = secret  # the device's pairing secret, read at each session's start
        self._auth: DeviceAuth | None = None  # the session's signer
        # For the plant's monitoring (device_manager/metrics.py).
        self.states_received = 0
        self.protective_stops = 0
        self._protective = False
        self.timing = timing or LinkSettings()
        self.status: ConnectionStatus = "connecting"
        self.last_error = ""
        self.connected_since: float | None = None
        self.info: dict[str, Any] | None = None
        self.last_state: str | None = None
        # One per session: a new session continues nothing of the old.
        self.generation = GENERATION_BASE
        self.ended: SessionEnded | None = None  # why the last session ended
        self.freshness = Freshness()
        self._on_state = on_state
        self._on_status = on_status
        self._tool_setup = tool_setup
        self._wake = asyncio.Event()
        self._stopping = False
        self._task: asyncio.Task[None] | None = None
        self._outbox: asyncio.Queue[str] | None = None  # the live session's commands
        self._http: httpx.AsyncClient | None = None
        self._routes: OrderedDict[int, Refusal] = OrderedDict()
        self._next_id = 0
        self.addresses = RecentAddresses()
        self._session_url: str | None = None  # where the live session is
        self._halts: dict[str, asyncio.Task[None]] = {}  # per address, a halt on its way
        # Why the link must stay where it is until the user moves it: its robot was moving
        # or in a fault when its last session ended ("" when it was at rest).
        self.held = ""

    @property
    def name(self) -> str:
        return self.record.local_name

    @property
    def pinned(self) -> str:
        """Why the link must not follow its device to another address by itself ("" if it
        may, once the device proves it serves from there)."""
        return "it is live" if self.status == "connected" else self.held

    @property
    def live(self) -> bool:
        """A session is up (for a device with a command session, that too)."""
        return self.status == "connected" and self._http is not None

    def start(self) -> None:
        self._task = asyncio.create_task(self._run(), name=f"device:{self.name}")

    async def stop(self) -> None:
        """Ends the session (the driver halts the robot as its session closes)."""
        task = self._task
        if task is None:
            return
        # The flag and the wake end the loop even if a library swallows the cancellation
        # (seen here: a session left streaming by a stop that did not arrive).
        self._stopping = True
        self._wake.set()
        task.cancel()
        # asyncio.wait never swallows a cancellation of our own caller, and the session
        # aborts its sockets rather than waiting for close handshakes.
        await asyncio.wait({task}, timeout=2.0)
        if not task.done():
            log.error("the session of %s did not end when stopped", self.name)
        if self._halts:  # a STOP on its way is not cut short
            await asyncio.wait(set(self._halts.values()), timeout=2.0)

    def move_to(self, url: str) -> None:
        """Reconnect at a new address now (the registry decides when that is right)."""
        self.record = self.record.model_copy(update={"url": url})
        self._wake.set()

    # Commands --------------------------------------------------------------------------------

    def send(self, command: dict[str, Any], generation: int, on_refused: Refusal) -> None:
        """Queue a command on this generation's session, in order; the driver's refusal, if
        any, goes to `on_refused`."""
        self._require(generation)
        if self._outbox is None:
            raise OpenPendantError(
                f"{self.name} takes no streamed commands (a {self.record.kind})",
                code="not_streamed",
                status=409,
            )
        self._next_id += 1
        ident = self._next_id
        self._routes[ident] = on_refused
        while len(self._routes) > MAX_ROUTED:
            self._routes.popitem(last=False)
        try:
            self._outbox.put_nowait(json.dumps({**command, "id": ident}))
        except asyncio.QueueFull:
            raise Unavailable(
                f"{self.name} is not taking commands",
                code="link_stale",
                words=words("link.stale", device=self.name),
            ) from None

    def halt(self, tag: str | None = None) -> bool:
        """Stop always wins: on whatever session is live, and to every other address the link
        used in the last minute or points at now. False when no session is live (then the
        driver has halted by itself, its session closed)."""
        queued = False
        if self._outbox is not None:
            with contextlib.suppress(asyncio.QueueFull):
                self._outbox.put_nowait(json.dumps({"type": "halt", "tag": tag}))
                queued = True
        self._halt_elsewhere(self._session_url if queued else None)
        return queued

    def _halt_elsewhere(self, reached: str | None) -> None:
        route = halt_route(self.record.kind)
        if route is None:
            return
        for url in {self.record.url, *self.addresses.recent()} - {reached}:
            if url in self._halts:
                continue  # one on its way already: a second would say nothing new
            task = asyncio.create_task(halt_at(url, route, self._secret(), self.name))
            self._halts[url] = task
            task.add_done_callback(functools.partial(self._halted, url))

    def _halted(self, url: str, _: asyncio.Task[None]) -> None:
        self._halts.pop(url, None)

    async def call(
        self, method: str, path: str, body: Any, generation: int, text: str | None = None
    ) -> tuple[int, Any]:
        """A request to the driver on this generation's session: (status, JSON body). `text`:
        the body as JSON text, sent as it is (the driver checks it as any body)."""
        self._require(generation)
        http = self._http
        assert http is not None
        if text is not None:
            sent: dict[str, Any] = {"content": text.encode(), "headers": JSON_TYPE}
        else:
            sent = {"json": body}
        try:
            response = await http.request(method, path, timeout=CALL_TIMEOUT, **sent)
        except httpx.HTTPError as exc:
            ended = self.ended
            if self.generation == generation and self._http is not http and ended is not None:
                # The session ended under the request (its client closed): say why.
                status = "stale" if ended.stale else "disconnected"
                raise Unavailable(
                    f"the link to {self.name} ended during the request: {short(str(ended))}",
                    code="link_stale" if ended.stale else "device_disconnected",
                    words=link_words(self.name, status),
                ) from exc
            raise Unavailable(
                f"{self.name} did not answer: {type(exc).__name__}", code="device_disconnected"
            ) from exc
        try:
            content = response.json() if response.content else None
        except ValueError:
            content = None
        return response.status_code, content

    async def open_stream(self, path: str, query: str = "") -> ClientConnection:
        """A socket of the driver's own (a camera's frames), signed as this runtime's, while
        the device is connected; large messages allowed (an image)."""
        if not self.live:
            code = "link_stale" if self.status == "stale" else "device_disconnected"
            raise Unavailable(
                f"{self.name} is {self.status}: {self.last_error}",
                code=code,
                words=link_words(self.name, self.status),
            )
        return await self._open(
            self.record.url, path, self._auth, query=query, max_size=MAX_STREAMED
        )

    def _require(self, generation: int) -> None:
        if self.generation != generation:
            raise OpenPendantError(
                f"the link to {self.name} was lost and made again since; nothing that was "
                "running on it continues",
                code="link_changed",
                status=409,
                words=words("link.changed", device=self.name),
            )
        if not self.live:
            code = "link_stale" if self.status == "stale" else "device_disconnected"
            raise Unavailable(
                f"{self.name} is {self.status}: {self.last_error}",
                code=code,
                words=link_words(self.name, self.status),
            )

    # Status ----------------------------------------------------------------------------------

    def _set_status(self, status: ConnectionStatus, error: str = "") -> None:
        changed = status != self.status or error != self.last_error
        self.status = status
        self.last_error = short(error)
        self.connected_since = time.time() if status == "connected" else None
        if status != "connected":
            self.last_state = None
        if changed:
            self._on_status(self)

    async def _run(self) -> None:
        attempt = 0
        while not self._stopping:
            self._wake.clear()
            try:
                ended = await self._session(self.record.url)
            except Exception as exc:  # a bug must not end the device's link for good
                log.exception("%s: session failed", self.name)
                ended = SessionEnded(f"internal error: {describe(exc)}")
            if ended is not None:  # it had connected: start again at once
                moves = declares(self.record.kind, "session")
                self.held = unsettled(self.last_state) if moves else ""
                self._set_status("stale" if ended.stale else "disconnected", str(ended))
                attempt = 0
            if self._wake.is_set():  # moved, or stopping
                continue
            delay = RETRY[min(attempt, len(RETRY) - 1)]
            attempt += 1
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(delay):
                    await self._wake.wait()

    async def _session(self, url: str) -> SessionEnded | None:
        """One session; returns why it ended if it had connected, else None (status set)."""
        state_ws: ClientConnection | None = None
        command_ws: ClientConnection | None = None
        secret = self._secret()
        # Bound to the driver process that answers its first request (GET /info).
        auth = DeviceAuth(secret) if secret else None
        self._auth = auth
        http = httpx.AsyncClient(
            base_url=url, timeout=CONNECT_TIMEOUT, auth=auth, verify=CLIENT_TLS
        )
        try:
            try:
                async with asyncio.timeout(CONNECT_TIMEOUT * 2):
                    info = await self._fetch_info(http, url)
                    if declares(self.record.kind, "tool"):
                        info = await self._apply_tool(http, info)
                    state_ws = await self._open(url, "/state/ws", None)
                    if declares(self.record.kind, "session"):
                        command_ws = await self._open(url, "/command/ws", auth)
                        timeout = self.timing.driver_timeout
                        await command_ws.send(json.dumps({"type": "session", "timeout": timeout}))
                    first = await state_ws.recv()
                    if declares(self.record.kind, "tool"):
                        first = await self._start_slow(http, state_ws, first)
            except InvalidStatus as exc:
                refused = exc.response.status_code == 401
                self._failed(
                    "the device refuses this runtime's commands: pair it (its pairing code)"
                    if refused
                    else f"cannot reach {url}: {describe(exc)}"
                )
                return None
            except (OSError, httpx.HTTPError, websockets.WebSocketException, TimeoutError) as exc:
                self._failed(f"cannot reach {url}: {describe(exc)}")
                return None
            except (WrongDevice, ValueError) as exc:
                self._failed(str(exc))
                return None
            return await self._connected(url, info, http, state_ws, command_ws, first)
        finally:
            for ws in (state_ws, command_ws):
                if ws is not None:
                    ws.transport.abort()  # no handshake to wait for, no queued data sent
            await http.aclose()

    async def _start_slow(
        self, http: httpx.AsyncClient, state_ws: ClientConnection, first: str | bytes
    ) -> str | bytes:
        """A robot whose link comes up (added, back, the runtime restarted) runs at no more
        than the site's first speed override: nobody's first hold after that is at full
        speed. Its first state then says so."""
        ratio = json.loads(first).get("speed_ratio")
        slow = self.timing.first_speed_ratio
        if not isinstance(ratio, int | float) or ratio <= slow + 1e-9:
            return first  # none to lower (a state that is no robot's is refused later)
        ep = endpoints(Robot)["set_speed_ratio"]
        response = await http.request(
            ep.method, ep.url(), json={"ratio": slow}, timeout=CALL_TIMEOUT
        )
        if response.status_code != 200:
            raise ValueError(
                f"its speed override could not be lowered: HTTP {response.status_code}"
            )
        log.info(
            "%s: speed override lowered from %.0f %% to %.0f %%", self.name, ratio * 100, slow * 100
        )
        return await state_ws.recv()

    async def _apply_tool(self, http: httpx.AsyncClient, info: dict[str, Any]) -> dict[str, Any]:
        """The stored tool setup, applied before anything moves: a robot never runs on a
        link with another TCP than the one its waypoints were taught with."""
        if self._tool_setup is None:
            return info
        try:
            setup = await self._tool_setup(self.name)
            if setup is None:
                return info
            return await send_tool_setup(http, setup)
        except OpenPendantError as exc:
            raise ValueError(f"its tool setup could not be applied: {exc.message}") from exc

    async def set_tool(self, setup: dict[str, Any]) -> dict[str, Any]:
        """A new tool setup on the live session; the links and the UI get the new info."""
        if not self.live or self._http is None:
            code = "link_stale" if self.status == "stale" else "device_disconnected"
            raise Unavailable(
                f"{self.name} is {self.status}: {self.last_error}",
                code=code,
                words=link_words(self.name, self.status),
            )
        try:
            info = await send_tool_setup(self._http, setup)
        except httpx.HTTPError as exc:
            raise Unavailable(
                f"{self.name} did not answer: {type(exc).__name__}", code="device_disconnected"
            ) from exc
        self.info = info
        self._on_status(self)
        return info

    def _failed(self, error: str) -> None:
        if short(error) != self.last_error:  # once per new reason, not once per attempt
            log.warning("%s: %s", self.name, short(error))
        self._set_status("disconnected", error)

    async def _connected(
        self,
        url: str,
        info: dict[str, Any],
        http: httpx.AsyncClient,
        state_ws: ClientConnection,
        command_ws: ClientConnection | None,
        first: str | bytes,
    ) -> SessionEnded:
        self.freshness.reset()
        text = first if isinstance(first, str) else first.decode()
        self._observe(text)
        self.info = info
        self.generation += 1
        self._http = http
        self._routes.clear()
        self._session_url = url
        self.addresses.used(url)
        self.held = ""
        if command_ws is not None:
            self._outbox = asyncio.Queue(MAX_QUEUED)
        log.info("%s connected at %s (link %d)", self.name, url, self.generation)
        self._set_status("connected")
        self._state(text)
        jobs = [self._read_states(state_ws), self._watch_wake()]
        if command_ws is not None:
            jobs += [self._write_commands(command_ws), self._read_refusals(command_ws)]
        tasks = [asyncio.create_task(job) for job in jobs]
        try:
            # Plain tasks, not a TaskGroup: on Python 3.11 a TaskGroup whose child fails
            # while it exits leaves a cancel request counted on this task, and a later
            # asyncio.timeout then takes a real cancellation for its own and swallows it.
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.wait(tasks)
            self._outbox = None
            self._http = None
            self._session_url = None
            self.addresses.used(url)
        ended = next(iter(done)).exception()
        if not isinstance(ended, SessionEnded):  # a bug: _run logs it and starts again
            raise ended or AssertionError("a session task returned")
        self.ended = ended
        log.warning("%s: link %d ended: %s", self.name, self.generation, ended)
        return ended

    # Session tasks ---------------------------------------------------------------------------

    async def _read_states(self, ws: ClientConnection) -> None:
        stale_after = self.timing.stale_after
        while True:
            try:
                async with asyncio.timeout(stale_after):
                    message = await ws.recv()
            except TimeoutError:
                raise SessionEnded(
                    f"stale: no state for {stale_after * 1000:.0f} ms", stale=True
                ) from None
            except websockets.WebSocketException as exc:
                raise SessionEnded(f"state stream closed: {describe(exc)}") from None
            text = message if isinstance(message, str) else message.decode()
            try:
                age = self._observe(text)
            except ValueError as exc:
                raise SessionEnded(f"malformed state: {exc}") from None
            if age > stale_after:
                raise SessionEnded(f"stale: states arrive {age * 1000:.0f} ms late", stale=True)
            self._state(text)

    def _observe(self, text: str) -> float:
        stamp = state_stamp(text)
        age = self.freshness.observe(stamp.seqno, stamp.ts)
        # Only a moving device's state changes every cycle; others repeat theirs at rest.
        return age if declares(self.record.kind, "session") else 0.0

    def _state(self, text: str) -> None:
        self.last_state = text
        self.states_received += 1
        stopped = PROTECTIVE_STOP.search(text) is not None
        if stopped and not self._protective:
            self.protective_stops += 1
        self._protective = stopped
        self._on_state(self, text)

    async def _watch_wake(self) -> None:
        await self._wake.wait()
        raise SessionEnded(f"moved to {self.record.url}")

    async def _write_commands(self, ws: ClientConnection) -> None:
        assert self._outbox is not None
        outbox = self._outbox
        keepalive = self.timing.driver_timeout / 4
        quiet = json.dumps({"type": "keepalive"})
        try:
            while True:
                try:
                    async with asyncio.timeout(keepalive):
                        text = await outbox.get()
                except TimeoutError:
                    text = quiet
                await ws.send(text)
        except websockets.WebSocketException as exc:
            raise SessionEnded(f"command stream closed: {describe(exc)}") from None

    async def _read_refusals(self, ws: ClientConnection) -> None:
        try:
            async for message in ws:
                body = json.loads(message)
                if not isinstance(body, dict):
                    continue
                route = self._routes.get(body.get("id"))  # type: ignore[arg-type]
                if route is not None:
                    route(body.get("error") or {})
                else:
                    log.warning("%s refused: %s", self.name, short(str(body.get("error"))))
        except (websockets.WebSocketException, ValueError) as exc:
            raise SessionEnded(f"command stream closed: {describe(exc)}") from None
        raise SessionEnded("the driver closed the command stream")

    # Set-up ----------------------------------------------------------------------------------

    async def _fetch_info(self, http: httpx.AsyncClient, url: str) -> dict[str, Any]:
        info = await fetch_info(http, url)
        identity = info.get("identity")
        uuid = identity.get("uuid") if isinstance(identity, dict) else None
        if uuid != self.record.uuid:
            shown = short(repr(uuid)[:80])
            raise WrongDevice(f"another device (uuid {shown}) answers at {url}")
        return info

    async def _open(
        self,
        url: str,
        path: str,
        auth: DeviceAuth | None,
        query: str = "",
        max_size: int = MAX_STATE,
    ) -> ClientConnection:
        ws_url = url.replace("http://", "ws://", 1).replace("https://", "wss://", 1)
        headers = {HEADER: auth.header("GET", path)} if auth else {}
        return await websockets.connect(
            ws_url + path + (f"?{query}" if query else ""),
            open_timeout=CONNECT_TIMEOUT,
            close_timeout=0.2,
            max_size=max_size,
            additional_headers=headers,
            # A state 100 times a second is ~150 kB/s plain: nothing for a cell's network,
            # while deflating it costs both ends CPU (a driver may run on a small board).
            compression=None,
        )


async def fetch_info(http: httpx.AsyncClient, url: str) -> dict[str, Any]:
    """A device's GET /info, read no further than MAX_INFO bytes."""
    async with http.stream("GET", "/info") as response:
        response.raise_for_status()
        raw = bytearray()
        async for chunk in response.aiter_bytes():
            raw += chunk
            if len(raw) > MAX_INFO:
                raise ValueError(f"{url}/info is over {MAX_INFO // 1024} KiB")
    info = json.loads(raw)
    if not isinstance(info, dict):
        raise ValueError(f"{url}/info is not a JSON object")
    return info


def describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
