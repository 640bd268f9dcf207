"""The link socket (`WS /devices/_links`): how every service uses the device manager's one
link per device. A service watches devices (their states are pushed, newest only, each
tagged with its link generation), sends commands and calls on a generation, and halts.

Frames carry one or more lines. A state is `S <device> <generation> <state JSON>`; every
other line is a JSON object: `link` (a device's link status, generation, address and
description), `devices` (the added list, as on /devices/ws), `refused` (a command of yours
the driver or the link refused), `reply` (to a call).

A service whose socket closes (it died or restarted) leaves nothing moving: every robot it
was the last to command, or claimed for a program run, is halted."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections import deque
from collections.abc import Mapping
from typing import Any, Protocol

from starlette.websockets import WebSocket, WebSocketDisconnect

from openpendant.runtime.device_manager.claims import MAX_CLAIM, Claims
from openpendant.runtime.device_manager.connection import DeviceConnection
from openpendant.runtime.kit.errors import NotFound, OpenPendantError

log = logging.getLogger(__name__)

MAX_EVENTS = 2000
# Commands that set the robot moving (or could): their sender is then its commander.
PASSIVE = {"halt", "keepalive"}


class LinkClient:
    """One service's socket: what it watches, the robots it must not leave moving."""

    def __init__(self, ws: WebSocket) -> None:
        self.ws = ws
        self.service = "a service"
        self.watching: set[str] = set()
        self.watch_all = False
        self.claimed: dict[str, int] = {}  # device -> generation
        self._states: dict[str, str] = {}
        self._events: deque[str] = deque()
        self._ready = asyncio.Event()
        self.overflowed = False
        self.calls: set[asyncio.Task[None]] = set()

    def watches(self, device: str) -> bool:
        return self.watch_all or device in self.watching

    def push_state(self, device: str, line: str) -> None:
        self._states.pop(device, None)
        self._states[device] = line
        self._ready.set()

    def push_event(self, message: dict[str, Any]) -> None:
        if len(self._events) >= MAX_EVENTS:
            self.overflowed = True
        else:
            self._events.append(json.dumps(message))
        self._ready.set()

    async def send_loop(self) -> None:
        while True:
            await self._ready.wait()
            self._ready.clear()
            if self.overflowed:
                log.warning("%s fell behind on link events; closing its socket", self.service)
                return
            lines = list(self._events)
            self._events.clear()
            lines.extend(self._states.values())
            self._states.clear()
            if lines:
                await self.ws.send_text("\n".join(lines))


class Devices(Protocol):
    """What the link server reads of the registry that owns it."""

    @property
    def connections(self) -> Mapping[str, DeviceConnection]: ...

    def devices_message(self) -> str: ...


class LinkServer:
    def __init__(self, registry: Devices) -> None:
        self.registry = registry
        self.clients: set[LinkClient] = set()
        # device -> (client, generation): the last to command it, halted if it goes away.
        self.commanders: dict[str, tuple[LinkClient, int]] = {}
        self.claims = Claims()

    # From the registry -------------------------------------------------------------------

    def on_state(self, conn: DeviceConnection, text: str) -> None:
        if not self.clients:
            return
        if "\n" in text:  # JSON whitespace only, never inside a string: framing stays intact
            text = text.replace("\n", " ")
        line = f"S {conn.name} {conn.generation} {text}"
        for client in self.clients:
            if client.watches(conn.name):
                client.push_state(conn.name, line)

    def on_status(self, conn: DeviceConnection) -> None:
        message = link_message(conn)
        for client in self.clients:
            client.push_event(message)

    def on_removed(self, name: str) -> None:
        self.commanders.pop(name, None)
        for client in self.clients:
            client.claimed.pop(name, None)
            client.push_event({"type": "link", "device": name, "status": "removed", "gen": -1})

    def on_devices(self, message: str) -> None:
        body = json.loads(message)
        for client in self.clients:
            client.push_event(body)

    # One socket ----------------------------------------------------------------------------

    async def serve(self, ws: WebSocket) -> None:
        await ws.accept()
        client = LinkClient(ws)
        for conn in self.registry.connections.values():
            client.push_event(link_message(conn))
        client.push_event(json.loads(self.registry.devices_message()))
        self.clients.add(client)
        sender = asyncio.create_task(client.send_loop())
        receiver = asyncio.create_task(self._receive(client))
        try:
            await asyncio.wait({sender, receiver}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            self.clients.discard(client)
            sender.cancel()
            receiver.cancel()
            for task in (sender, receiver, *client.calls):
                task.cancel()
            self._left(client)
            await asyncio.wait({sender, receiver, *client.calls}, timeout=1.0)
            with contextlib.suppress(RuntimeError, OSError, WebSocketDisconnect):
                await ws.close()

    def _left(self, client: LinkClient) -> None:
        """A service went away: nothing it set moving keeps moving. Its claims end first,
        in the same step, so no command for its runs reaches a device after the halt."""
        self.claims.end_all(client)
        held = dict(client.claimed)
        for device, (commander, generation) in list(self.commanders.items()):
            if commander is client:
                del self.commanders[device]
                held.setdefault(device, generation)
        for device, generation in held.items():
            conn = self.registry.connections.get(device)
            if (
                conn is not None
                and conn.generation == generation
                and conn.halt(f"{client.service} link closed")
            ):
                log.warning("halting %s: its link to %s closed", device, client.service)

    async def _receive(self, client: LinkClient) -> None:
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                text = await client.ws.receive_text()
                try:
                    message = json.loads(text)
                    if not isinstance(message, dict):
                        raise ValueError("not an object")
                except ValueError:
                    client.push_event(_error(None, "bad_message", "a message is a JSON object"))
                    continue
                try:
                    self._handle(client, message)
                except (ValueError, TypeError, KeyError) as exc:
                    client.push_event(_error(message.get("ref"), "bad_message", str(exc)[:200]))

    def _handle(self, client: LinkClient, message: dict[str, Any]) -> None:
        op = message.get("op")
        device = message.get("device")
        if op == "hello":
            client.service = str(message.get("service", "a service"))[:40]
        elif op == "watch":
            self._watch(client, message.get("devices"))
        elif op == "halt":
            conn = self.registry.connections.get(str(device))
            if conn is not None:
                tag = message.get("tag")
                conn.halt(tag[:64] if isinstance(tag, str) else None)
                self._forget_commander(str(device), client)
        elif op == "send":
            self._send(client, message)
        elif op == "call":
            task = asyncio.create_task(self._call(client, message))
            client.calls.add(task)
            task.add_done_callback(client.calls.discard)
        elif op == "claim":
            conn = self.registry.connections.get(str(device))
            if conn is not None:
                client.claimed[conn.name] = int(message.get("gen", conn.generation))
            claim = _claim_of(message)
            if claim is not None:
                self.claims.take(claim, client)
        elif op == "unclaim":
            client.claimed.pop(str(device), None)
            claim = _claim_of(message)
            if claim is not None:
                self.claims.end(claim)
        else:
            client.push_event(_error(message.get("ref"), "bad_message", f"unknown op {op!r}"))

    def _watch(self, client: LinkClient, devices: Any) -> None:
        if devices == "*":
            client.watch_all, client.watching = True, set()
        elif isinstance(devices, list):
            client.watch_all, client.watching = False, {str(d) for d in devices}
        for name, conn in self.registry.connections.items():
            if client.watches(name) and conn.last_state is not None:
                self.on_state(conn, conn.last_state)

    def _send(self, client: LinkClient, message: dict[str, Any]) -> None:
        ref = message.get("ref")
        name = str(message.get("device"))
        command = message.get("command")
        generation = message.get("gen")
        if not isinstance(command, dict) or not isinstance(generation, int):
            client.push_event(_error(ref, "bad_message", "send needs a command and a gen"))
            return

        def refused(error: dict[str, Any]) -> None:
            client.push_event(
                {"type": "refused", "device": name, "gen": generation, "ref": ref, "error": error}
            )

        try:
            claim = _claim_of(message)
            if claim is not None and not self.claims.live(claim):
                # A stream's commands come too often to wait: its sender makes sure of the
                # claim first (a call under it, which waits for it, switches the mode).
                raise _not_live(claim, str(command.get("type")))
            conn = self._connection(name)
            conn.send(command, generation, refused)
            if claim is not None:
                self._held_for(claim, name, generation)
        except ValueError as exc:
            refused({"code": "bad_message", "message": str(exc)})
            return
        except OpenPendantError as exc:
            refused(exc.body()["error"])
            return
        if command.get("type") not in PASSIVE:
            self.commanders[name] = (client, generation)
        elif command.get("type") == "halt":
            self._forget_commander(name, client)

    async def _call(self, client: LinkClient, message: dict[str, Any]) -> None:
        ref = message.get("ref")
        name = str(message.get("device"))
        method = str(message.get("method", "GET")).upper()
        path = str(message.get("path", ""))
        generation = message.get("gen")
        reply: dict[str, Any] = {"type": "reply", "ref": ref, "device": name}
        try:
            if not path.startswith("/") or method not in ("GET", "POST", "PUT", "DELETE"):
                raise OpenPendantError("a call needs a method and a path", code="bad_message")
            if not isinstance(generation, int):
                raise OpenPendantError("a call needs the link generation", code="bad_message")
            text = message.get("body_text")
            if text is not None and not isinstance(text, str):
                raise OpenPendantError("a call's body_text is JSON text", code="bad_message")
            conn = self._connection(name)
            try:
                claim = _claim_of(message)
            except ValueError as exc:
                raise OpenPendantError(str(exc), code="bad_message") from None
            if claim is not None and not await self.claims.wait_live(claim):
                raise _not_live(claim, f"{method} {path}")
            if method != "GET":
                self.commanders[name] = (client, generation)
                if claim is not None:
                    self._held_for(claim, name, generation)
            status, body = await conn.call(method, path, message.get("body"), generation, text)
            if claim is not None and method != "GET" and not self.claims.live(claim):
                # Its caller went away while the command was on its way to the device (the
                # halt may have got there first): halted again, after it.
                conn.halt(f"{claim} ended")
            reply.update(status=status, body=body)
        except OpenPendantError as exc:
            reply.update(status=exc.status, body=exc.body())
        client.push_event(reply)

    def _held_for(self, claim: str, device: str, generation: int) -> None:
        """What a command under a claim started is the claimant's to answer for: halted
        when its link closes, on whatever generation the command went (a link made again
        since the claim was taken included)."""
        owner = self.claims.owner(claim)
        if isinstance(owner, LinkClient):
            owner.claimed[device] = generation

    def _connection(self, name: str) -> DeviceConnection:
        conn = self.registry.connections.get(name)
        if conn is None:
            raise NotFound(f"no device named {name!r}", code="device_not_found")
        return conn

    def _forget_commander(self, device: str, client: LinkClient) -> None:
        commander = self.commanders.get(device)
        if commander is not None and commander[0] is client:
            del self.commanders[device]


def _not_live(claim: str, what: str) -> OpenPendantError:
    return OpenPendantError(
        f"{what} was for {claim}, which is not live: its caller is gone, its run has ended, "
        "or it never claimed the robot",
        code="claim_ended",
        status=409,
    )


def _claim_of(message: dict[str, Any]) -> str | None:
    claim = message.get("claim")
    if claim is None:
        return None
    if not isinstance(claim, str) or not 0 < len(claim) <= MAX_CLAIM:
        raise ValueError(f"a claim is a string of 1 to {MAX_CLAIM} characters")
    return claim


def link_message(conn: DeviceConnection) -> dict[str, Any]:
    return {
        "type": "link",
        "device": conn.name,
        "kind": conn.record.kind,
        "status": conn.status,
        "gen": conn.generation,
        "url": conn.record.url,
        "error": conn.last_error,
        "info": conn.info if conn.status == "connected" else None,
    }


def _error(ref: Any, code: str, message: str) -> dict[str, Any]:
    return {"type": "refused", "ref": ref, "error": {"code": code, "message": message}}
